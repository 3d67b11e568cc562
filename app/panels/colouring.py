"""The header's colour control, first under *Playback and view*: the live cloud in true colour, in
its sources' colours or as the heat map, one choice per tab. True colour is offered while the
source gives colour, greyed out with why otherwise (the cloud then shows its sources' colours);
the heat map can colour one mirror's points alone; the legend follows the choice."""

from __future__ import annotations

from ..context import TabContext
from ..liveframe import LiveFrame
from ..wording.greyed import true_colour_greyed
from ..wording.legend import heat_legend_html, legend_html, source_names
from .planes import from_object, no_glass

TRUE_COLOUR, BY_SOURCE, HEAT_MAP = "true colour", "source", "heat map"
COLOURS = (TRUE_COLOUR, BY_SOURCE, HEAT_MAP)
EVERY_MIRROR = "every mirror"  # the heat map of every mirror's points (Heat map of)
COLOUR_HINT = (
    "true colour: each point as the camera saw it, the mirrors' tint undone; source: the camera's "
    "points grey, each mirror's in its colour; heat map: the mirrors' points by their distance "
    "to the surface the camera sees directly: white on it, red outside, blue inside (10 mm and "
    "more saturated), grey where there is nothing to compare; a frame a second, in the 3D "
    "scene, on the object (the colours are on its rims). It shows a tilt, hardly the glass: "
    "Refine from the object measures that"
)


def colour_choices(has_colour: bool) -> tuple[str, ...]:
    """The colour control's choices: true colour only for a source that gives colour.

    Parameters
    ----------
    has_colour : bool
        The source's frames carry colour (DepthSource.has_colour).

    Returns
    -------
    tuple of str
    """
    return COLOURS if has_colour else COLOURS[1:]


class ColourControl:
    """The colour control of one tab's header (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in, inside the folder it shows in.
    legend : viser.GuiHtmlHandle
        The header's legend, which it writes.
    """

    def __init__(self, tab: TabContext, legend):
        gui, self.tab, self._legend = tab.gui, tab, legend
        has_colour = tab.services.source.has_colour
        self.choice = gui.add_dropdown(
            "Colour",
            colour_choices(has_colour),
            initial_value=self.chosen_now(has_colour),
            hint=COLOUR_HINT,
        )
        self.greyed = gui.add_html("", visible=False)
        self.heat_of = gui.add_dropdown(
            "Heat map of", (EVERY_MIRROR,), initial_value=EVERY_MIRROR, visible=False
        )
        # the technician's choice; the server's own settings of the value are its echo
        self.choice.on_update(
            lambda e: e.client is not None and self.choose(self.choice.value, ticked=True)
        )
        self.heat_of.on_update(lambda _: tab.heat_only(self.heat_mirror()))
        self.follow()

    def chosen_now(self, has_colour: bool) -> str:
        """What the tab shows: the heat map, true colour (chosen, and the source gives colour) or
        the sources' colours."""
        tab = self.tab
        if tab.heat:
            return HEAT_MAP
        return TRUE_COLOUR if tab.true_colour and has_colour else BY_SOURCE

    def choose(self, choice: str, ticked: bool = False) -> None:
        """Colour the cloud as `choice` says.

        Parameters
        ----------
        choice : str
            One of COLOURS. True colour chosen for a source without colour is kept for the next
            source that has it; meanwhile the cloud shows its sources' colours.
        ticked : bool, optional
            Chosen by the technician: the heat map chosen while the depth frame is in view turns
            the view to the 3D scene, where it is drawn.
        """
        tab = self.tab
        if choice == HEAT_MAP:
            if ticked and tab.state.view == "depth":
                tab.look("3d")
            if not tab.heat:
                tab.show_heat(True)
        else:
            tab.colour_by(choice == TRUE_COLOUR)
        self.follow()

    def take_up(self, heat: bool, true_colour: bool) -> None:
        """Colour the cloud as the page's tab before did (a reload).

        Parameters
        ----------
        heat : bool
            Its heat map was on.
        true_colour : bool
            Its cloud was in true colour, else in its sources' colours.
        """
        self.choose(HEAT_MAP if heat else TRUE_COLOUR if true_colour else BY_SOURCE)

    def follow(self) -> None:
        """Offer the choices of the source that plays, show the tab's, say why one is greyed out.

        The heat map's mirrors too (heat_choices), and the legend of the last frame (while paused
        no new frame comes).
        """
        source = self.tab.services.source
        options, value = colour_choices(source.has_colour), self.chosen_now(source.has_colour)
        if self.choice.options != options:
            # the value is one of the options at every step
            if value in self.choice.options:
                self.choice.value = value
                self.choice.options = options
            else:
                self.choice.options = options
                self.choice.value = value
        elif self.choice.value != value:
            self.choice.value = value
        self.greyed.content = "" if source.has_colour else true_colour_greyed(source.name)
        self.greyed.visible = not source.has_colour
        frame = self.tab.services.last_frame
        if frame is not None:
            self.show_legend(frame)
        else:
            self.heat_choices()

    def heat_choices(self) -> None:
        """Offer, while the heat map shows, to colour one mirror's points alone.

        Every mirror with a plane, when there are two or more; a mirror chosen and since removed (or
        its plane cleared) goes back to all.
        """
        names = tuple(
            m.name for m in self.tab.services.snapshot.session.mirrors if m.plane is not None
        )
        choices = (EVERY_MIRROR, *names)
        if self.heat_of.options != choices:
            if self.heat_of.value not in choices:
                self.heat_of.value = EVERY_MIRROR
                self.tab.heat_only(None)
            self.heat_of.options = choices
        self.heat_of.visible = self.tab.heat and len(names) > 1

    def heat_mirror(self) -> int | None:
        """The id of the mirror the heat map is of (the dropdown's name), None for every mirror."""
        session = self.tab.services.snapshot.session
        return next((m.id for m in session.mirrors if m.name == self.heat_of.value), None)

    def show_legend(self, frame: LiveFrame) -> None:
        """Write the legend of what the tab shows, and offer the heat map's mirrors.

        Parameters
        ----------
        frame : LiveFrame
            The frame shown.
        """
        self._legend.content = self.legend(frame)
        self.heat_choices()

    def legend(self, frame: LiveFrame) -> str:
        """The legend of what the tab shows (HTML).

        The heat map's key and figures while it shows in the 3D scene; else the points per source,
        in true colour (with the mirrors whose tint stays) or in the sources' colours, and the
        mirrors with no plane yet.

        Parameters
        ----------
        frame : LiveFrame
            The frame shown.

        Returns
        -------
        str
            HTML.
        """
        tab, jobs = self.tab, self.tab.services.jobs
        session = frame.snapshot.session
        names = source_names(session)
        if tab.heat and tab.state.view == "3d":
            return heat_legend_html(
                tab.heat_figures,
                tab.heat_frames,
                names,
                from_object(jobs, session),
                any(m.plane is not None for m in session.mirrors),
                bool(no_glass(jobs, session)),
            )
        return legend_html(
            frame.counts,
            names,
            frame.mirror_ids,
            tuple(m.name for m in session.mirrors if m.plane is None),
            tab.true_colour and frame.cloud.rgb is not None,
            tuple(m.name for m in session.mirrors if m.plane is not None and m.colour_gain is None),
        )
