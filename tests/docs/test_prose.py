"""README.md is a front door and docs/ a guide: short pages, short paragraphs, short sentences.

`.venv/bin/python -m tests.docs.test_prose` prints the figures.
"""
from __future__ import annotations

import pytest

from tests.docs.markdown import (ROOT, blocks, documents, guide, median_sentence, prose_sentences,
                                 sentences, words)

README = ROOT / "README.md"
MAX_README_LINES = 200
MAX_PARAGRAPH = 120       # words of a paragraph, list item, table row or code line
MAX_MEDIAN_SENTENCE = 25  # words


def longest(path) -> tuple[int, str]:
    units = blocks(path.read_text())
    return max(((words(text), text) for kind, text in units if kind != "heading"), default=(0, ""))


def test_readme_is_a_front_door():
    assert len(README.read_text().splitlines()) <= MAX_README_LINES


@pytest.mark.parametrize("path", documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_paragraph_runs_over_120_words(path):
    count, text = longest(path)
    assert count <= MAX_PARAGRAPH, f"{path.relative_to(ROOT)}: {count} words in '{text[:80]} ...'"


def test_median_sentence_is_short():
    assert median_sentence([p for p in documents() if guide(p)]) < MAX_MEDIAN_SENTENCE


def test_figures_count_what_a_reader_reads():
    text = "Intro [a link](docs/x.md#y) here. Second one.\n\n- item one\n- item two\n\n| a | b |\n"
    assert [kind for kind, _ in blocks("# Head\n\n" + text + "```\ncode\n```\n")] == [
        "heading", "paragraph", "item", "item", "row", "code"]
    assert sentences("Intro [a link](docs/x.md#y) here. Second one.") == [
        "Intro a link here.", "Second one."]
    assert words("Intro [a link](docs/x.md#y) here.") == 4


def report() -> str:
    docs = [p for p in documents() if guide(p)]
    lines = [f"README.md: {len(README.read_text().splitlines())} lines, longest paragraph "
             f"{longest(README)[0]} words, median sentence {median_sentence([README])} words"]
    count = sum(len(prose_sentences(p)) for p in docs)
    most = max(longest(p)[0] for p in docs)
    lines += [f"README and docs (guide): longest paragraph {most} words, "
              f"median sentence {median_sentence(docs)} words over {count} sentences"]
    lines += [f"  {p.relative_to(ROOT)}: longest {longest(p)[0]}, "
              f"median sentence {median_sentence([p])}" for p in documents()]
    return "\n".join(lines)


if __name__ == "__main__":
    print(report())
