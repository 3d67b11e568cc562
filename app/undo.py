"""The session editor's undo and redo history: one stack of steps per scope (a mirror's id, or
SESSION_SCOPE for the session's own changes), each step named for the Undo button.

The planes set by one fit or refinement of several mirrors share a group: undo and redo move
every step of the group that is still the last of its mirror. Not thread-safe: the editor
calls it under its own lock.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Callable, Iterable

from mirrorcore.base.words import listed
from mirrorcore.io.session import Session, SessionMirror

from .guards import SESSION_SCOPE, fit_inputs

UNDO_DEPTH = 100
# In the label of a group's step that moves only part of its mirrors (the others changed since).
PARTIAL = " only: "


@dataclass(frozen=True)
class Step:
    """One undoable change.

    Attributes
    ----------
    label : str
        Its name on the button ('marker 2.3', 'remove mirror 1').
    before, after : object
        What undo and redo put back. In a mirror's scope, its SessionMirror before and after; in
        the session's scope, the change that undoes it and the change itself, (kind, a, b) as
        `restore` reads them.
    group : int
        Ties the steps of several mirrors made by one action (0: none).
    what : str
        Of a planes step: what each mirror's change is ('plane' from the markers, 'refined
        plane'); names a part of a group and tells a markers fit.
    order : int
        When the step was made, undone or redone last: which history holds the newest step.
    """

    label: str
    before: object
    after: object
    group: int = 0
    what: str = ""
    order: int = 0


def inverse(change: tuple) -> tuple:
    """The session change that undoes `change`.

    An added mirror is removed, a removed one put back, any other value swapped back.

    Parameters
    ----------
    change : tuple
        (kind, a, b), as `restore` reads it.

    Returns
    -------
    tuple
        (kind, a, b).
    """
    kind, a, b = change
    if kind == "add":
        return ("remove", a, b)
    if kind == "remove":
        return ("add", a, b)
    return (kind, b, a)


def touched(scope: int, change) -> list[int]:
    """The scopes a step's side changes: its own and, adding or removing a mirror, that mirror's.

    Parameters
    ----------
    scope : int
        A mirror's id, or SESSION_SCOPE.
    change : SessionMirror or tuple
        One side of the step, as `restore` reads it.

    Returns
    -------
    list of int
    """
    if scope == SESSION_SCOPE and change[0] in ("add", "remove"):
        return [scope, change[2].id]
    return [scope]


def restore(session: Session, scope: int, state) -> Session:
    """The session with one side of a step put back.

    Parameters
    ----------
    session : Session
    scope : int
        A mirror's id, or SESSION_SCOPE.
    state : SessionMirror or tuple
        In a mirror's scope, its record; in the session's, a change (kind, a, b):
        ("add", index, mirror) puts the mirror back at `index`, ("remove", index, mirror) takes it
        out, any other kind sets that field of the session to `b`.

    Returns
    -------
    Session
    """
    if scope != SESSION_SCOPE:
        index = next(i for i, m in enumerate(session.mirrors) if m.id == scope)
        return session.with_mirror(index, state)
    kind, a, b = state
    if kind == "add":
        return replace(session, mirrors=session.mirrors[:a] + (b,) + session.mirrors[a:])
    if kind == "remove":
        return replace(session, mirrors=tuple(m for m in session.mirrors if m.id != b.id))
    return replace(session, **{kind: b})


class History:
    """The undo and redo stacks of every scope, capped at UNDO_DEPTH steps a scope.

    Attributes
    ----------
    undo, redo : dict of int to list of Step
        By scope (a mirror's id, or SESSION_SCOPE), oldest step first.
    """

    def __init__(self) -> None:
        self.undo: dict[int, list[Step]] = {}
        self.redo: dict[int, list[Step]] = {}
        self._groups = itertools.count(1)
        self._orders = itertools.count(1)

    def stacks(self, redo: bool) -> dict[int, list[Step]]:
        """The redo stacks when `redo`, else the undo stacks.

        Parameters
        ----------
        redo : bool

        Returns
        -------
        dict of int to list of Step
        """
        return self.redo if redo else self.undo

    def new_group(self) -> int:
        """A group number no step holds yet."""
        return next(self._groups)

    def record(self, scope: int, step: Step) -> None:
        """Push a new step on the undo stack of `scope`; its redo stack is dropped.

        Parameters
        ----------
        scope : int
            A mirror's id, or SESSION_SCOPE.
        step : Step
            The change; its `order` is set here.
        """
        step = replace(step, order=next(self._orders))
        self.undo[scope] = (self.undo.get(scope, []) + [step])[-UNDO_DEPTH:]
        self.redo.pop(scope, None)

    def scope(self, mirror_id: int | None, redo: bool = False) -> int:
        """Where undo (or redo) acts for the selected mirror.

        The mirror's own history, or the session's when the mirror's holds nothing or the
        session's last step is a removal made, undone or redone after the mirror's last. An added
        mirror is not taken back over the selected one's steps: its undo would take the new
        mirror's work with it.

        Parameters
        ----------
        mirror_id : int or None
            The selected mirror.
        redo : bool, optional
            For redo rather than undo.

        Returns
        -------
        int
            `mirror_id`, or SESSION_SCOPE.
        """
        source = self.stacks(redo)
        own = source.get(mirror_id) if mirror_id else None
        shared = source.get(SESSION_SCOPE)
        if not own:
            return SESSION_SCOPE
        removal = (bool(shared) and shared[-1].after[0] == "remove"
                   and shared[-1].order > own[-1].order)
        return SESSION_SCOPE if removal else mirror_id

    def split(self, step: Step, redo: bool,
              mirror_ids: Iterable[int]) -> tuple[list[int], list[int]]:
        """The mirrors of `step`'s group that move with it, and those that stay.

        Parameters
        ----------
        step : Step
        redo : bool
            Read the redo stacks instead of the undo stacks.
        mirror_ids : iterable of int
            The mirrors present, in session order.

        Returns
        -------
        moving, staying : list of int
            Those whose last step is of the group, and those that hold it under later steps.
            Both empty for a step of no group.
        """
        if not step.group:
            return [], []
        source = self.stacks(redo)
        holding = [i for i in mirror_ids if any(x.group == step.group for x in source.get(i, ()))]
        moving = [i for i in holding if source[i][-1].group == step.group]
        return moving, [i for i in holding if i not in moving]

    def label(self, scope: int, redo: bool, mirror_ids: Iterable[int],
              name: Callable[[int], str]) -> str | None:
        """The label of the last step of `scope`, or None when there is none.

        A group's step of which some mirrors changed since names only the mirrors it would move, and
        those that changed ('refined plane of mirror 2 only: mirror 1 changed since').

        Parameters
        ----------
        scope : int
            A mirror's id, or SESSION_SCOPE.
        redo : bool
            Read the redo stacks instead of the undo stacks.
        mirror_ids : iterable of int
            The mirrors present, in session order.
        name : callable
            A mirror's name from its id.

        Returns
        -------
        str or None
        """
        steps = self.stacks(redo).get(scope)
        if not steps:
            return None
        step = steps[-1]
        if not step.group:
            return step.label
        moving, left = self.split(step, redo, mirror_ids)
        plural = "s" if len(moving) > 1 else ""
        label = f"{step.what}{plural} of {listed([name(i) for i in moving])}"
        return f"{label}{PARTIAL}{listed([name(i) for i in left])} changed since" if left else label

    def travel(self, scope: int, redo: bool, mirror_ids: Iterable[int]) -> list[tuple[int, Step]]:
        """Move the last step of `scope` to the other history.

        The rest of its group that is still last in its scope moves with it.

        Parameters
        ----------
        scope : int
            A mirror's id, or SESSION_SCOPE.
        redo : bool
            Move from the redo stacks to the undo stacks (else the other way).
        mirror_ids : iterable of int
            The mirrors present, in session order.

        Returns
        -------
        list of (scope, Step)
            The steps moved; the caller puts back their `before` (undo) or `after` (redo).
            Empty when `scope` has nothing to move.
        """
        source, target = (self.redo, self.undo) if redo else (self.undo, self.redo)
        moving = self.peek(scope, redo, mirror_ids)
        order = next(self._orders)
        for s, step in moving:
            source[s].pop()
            target.setdefault(s, []).append(replace(step, order=order))
        return moving

    def peek(self, scope: int, redo: bool, mirror_ids: Iterable[int]) -> list[tuple[int, Step]]:
        """What `travel` would move, without moving it.

        Parameters
        ----------
        scope : int
            A mirror's id, or SESSION_SCOPE.
        redo : bool
            Read the redo stacks instead of the undo stacks.
        mirror_ids : iterable of int
            The mirrors present, in session order.

        Returns
        -------
        list of (scope, Step)
            Empty when `scope` has nothing to move.
        """
        source = self.stacks(redo)
        steps = source.get(scope)
        if not steps:
            return []
        return [(s, source[s][-1]) for s in self.split(steps[-1], redo, mirror_ids)[0] or [scope]]

    def removal(self, scope: int, redo: bool, mirror_ids: Iterable[int]) -> int | None:
        """The mirror that `travel` of `scope` would remove.

        Parameters
        ----------
        scope : int
            A mirror's id, or SESSION_SCOPE.
        redo : bool
            Read the redo stacks instead of the undo stacks.
        mirror_ids : iterable of int
            The mirrors present, in session order.

        Returns
        -------
        int or None
            Its id; None when it would remove none.
        """
        mirror_ids = list(mirror_ids)
        for s, step in self.peek(scope, redo, mirror_ids):
            change = step.after if redo else step.before
            if s == SESSION_SCOPE and change[0] == "remove" and change[2].id in mirror_ids:
                return change[2].id
        return None

    def glass_unused(self, mirror_id: int) -> bool:
        """Whether the mirror's glass was typed in after its plane was set.

        Its undo steps, newest first, change the glass before they change the plane: the plane
        stands where the last fit put it until the next fit.

        Parameters
        ----------
        mirror_id : int

        Returns
        -------
        bool
        """
        for step in reversed(self.undo.get(mirror_id, [])):
            if step.before.plane != step.after.plane:
                return False
            if step.before.marker_offset != step.after.marker_offset:
                return step.after.plane is not None
        return False

    def fitted_on(self, mirror_id: int, now: SessionMirror | None) -> bool:
        """Whether the newest step that set the mirror's plane is a markers fit on what it has now.

        A markers fit is a step whose `what` is 'plane'; it must have been made on the markers,
        boundary, region, plane and glass that `now` has.

        Parameters
        ----------
        mirror_id : int
        now : SessionMirror or None
            The mirror as it is.

        Returns
        -------
        bool
        """
        step = next((s for s in reversed(self.undo.get(mirror_id, []))
                     if s.before.plane != s.after.plane), None)
        return (step is not None and step.what == "plane" and now is not None
                and fit_inputs(step.after) == fit_inputs(now))
