"""The side panel's steps, one module each, in the order of the work; each panel is built per tab
from a app.context.TabContext and adds one tab of the tab group (TITLE). The status header above
them is panels.live."""

from __future__ import annotations

from .dense import DensePanel
from .measure import MeasurePanel
from .mirrors import MirrorsPanel
from .object import ObjectPanel
from .record import RecordPanel
from .session import SessionPanel

PANELS = (MirrorsPanel, ObjectPanel, MeasurePanel, DensePanel, RecordPanel, SessionPanel)
