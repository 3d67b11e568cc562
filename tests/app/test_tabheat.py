"""A tab's heat map (mirrorscan.tabheat): the mirrors' points compared with the camera's surface
show in their colours, large; the camera's, the other mirrors' and those with nothing to compare
with are small and grey, so that a person's few compared points do not drown in grey."""
import threading
from types import SimpleNamespace

import numpy as np
from mirrorscan.events import HeatChanged
from mirrorscan.tabheat import TabHeat

from mirrorcore.base.palette import HEAT_UNCOMPARED, SOURCE_COLOURS


class Drawn(TabHeat):
    """A TabHeat whose scene keeps what it was asked to draw."""

    def __init__(self, mirror_ids):
        self.shown = None
        self.scene = SimpleNamespace(show_heat=lambda *args: setattr(self, "shown", args))
        session = SimpleNamespace(mirrors=[SimpleNamespace(id=i) for i in mirror_ids])
        self.services = SimpleNamespace(snapshot=SimpleNamespace(session=session))
        self.heat, self.closed, self.heat_of = True, False, None
        self._heat_lock = threading.Lock()


def test_points_with_nothing_to_compare_are_drawn_small_and_grey_as_the_cameras():
    red, white = np.array([230, 40, 30]), np.array([250, 250, 250])
    sources = np.array([0, 1, 1, 2, 2], np.uint8)
    colours = np.array([SOURCE_COLOURS[0], red, HEAT_UNCOMPARED, white, HEAT_UNCOMPARED],
                       np.uint8)
    tab = Drawn((7, 9))
    tab._on_heat(HeatChanged(3, np.zeros((5, 3), np.float32), colours, {}, 1, sources))
    _, drawn, small = tab.shown
    assert small.tolist() == [True, False, True, False, True]
    assert np.array_equal(drawn[[1, 3]], [red, white])
    assert np.array_equal(drawn[[2, 4]], [SOURCE_COLOURS[0]] * 2)
    # one mirror's alone: the other's compared points are small and grey too
    tab.heat_only(9)
    _, drawn, small = tab.shown
    assert small.tolist() == [True, True, True, False, True]
    assert np.array_equal(drawn[1], SOURCE_COLOURS[0])
