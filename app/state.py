"""The server's shared state: the session and what is derived from it (rig, selection, background), swapped whole
under a lock so that the live loop and the browser callbacks always see one consistent snapshot."""
from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from mirrorcore.rig import Rig
from mirrorcore.session import Session


@dataclass(frozen=True, eq=False)
class Snapshot:
    """One consistent state: the session, its rig (reflection tables built once) and the background depth (H, W)
    metres or None."""

    session: Session
    rig: Rig
    background: np.ndarray | None

    @classmethod
    def build(cls, session: Session, background: np.ndarray | None) -> "Snapshot":
        rig = Rig.from_session(session)
        rig.reflection_table  # built here, once, not in the first live frame
        return cls(session, rig, background)


class SharedState:
    """The current Snapshot, replaced atomically; readers take `current` and keep using it for a whole frame."""

    def __init__(self, snapshot: Snapshot):
        self._lock = threading.Lock()
        self._snapshot = snapshot

    @property
    def current(self) -> Snapshot:
        with self._lock:
            return self._snapshot

    def replace(self, snapshot: Snapshot) -> None:
        with self._lock:
            self._snapshot = snapshot
