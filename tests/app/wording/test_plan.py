"""The plan's words in the browser: short headlines, figures in the details."""

import numpy as np

from mirrorcore.plan.coverage import Coverage
from mirrorscan.wording import HEADLINE_WORDS, words
from mirrorscan.wording import plan as plan_words


def test_the_plan_messages_have_short_headlines_and_figures_in_details():
    seen = np.array([[True, True, False, False], [False, True, True, False],
                     [False, True, False, False], [False, True, False, False]])
    depth = np.where(seen, 2.0, 0.0).astype(np.float32)
    cov = Coverage(((), (0,), (1,), (0, 1)), seen, depth, np.full(4, 0.25))
    figures = plan_words.figures(cov, 0.016)
    assert "75.0%" in figures.headline and "25.0%" in figures.headline
    assert "| mirror 1 then 2 | 25.0% | 5.7 mm |" in figures.details[0]
    assert "16 ms" in figures.details[1]
    messages = [figures, plan_words.refused("mirror 2: outside the room by 0.12 m"),
                plan_words.optimised(0.848, 0.867, 6.3),
                plan_words.simulating("http://127.0.0.1:8081/", None),
                plan_words.simulating("http://127.0.0.1:8081/", "mirror 2: markers collinear")]
    for message in messages:
        assert words(message.headline) <= HEADLINE_WORDS, message.headline
    assert "<details>" in plan_words.simulating("u", "why").markdown()
