"""Whether a browser tab is there for the live cloud: which page it is (kept through reloads, the
work of its tab before taken up), whether it is hidden, and whether it keeps up with what it is
sent.

viser has no message for a tab's visibility: the page notes it in its localStorage, which the
server reads (`poll_visibility`); how long that answer takes tells whether the tab lags.

What the page has been sent is known to be there once the page answers a question sent after it
(`seen`): a click that comes before that answer was made on the page as it was before.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, replace

import numpy as np
import viser
from viser import _messages

from mirrorcore.io.session import Session

from .context import TabState

# seconds: a tab that takes longer to answer the visibility poll lags. Frames wait in its
# browser to be drawn, so it is sent no live cloud and no depth frame until it answers in time;
# otherwise a tab that draws slower than the loop sends would show frames minutes late.
MAX_LAG_S = 0.5
SETTLING_S = 5.0        # seconds after a tab opens while its page builds: it may lag, unreported
ACK_TIMEOUT_S = 2.0     # seconds the page may take to answer that it has what it was sent
HIDDEN_KEY = "mirrorscan-hidden"
PAGE_KEY = "mirrorscan-page"
PAGE_NAME_CHARS = 64
# A browser tab keeps its sessionStorage through reloads and no other tab shares it: the page's
# name, made once.
PAGE_JS = """(() => {{
  let page = sessionStorage.getItem("{key}");
  if (!page) {{
    page = Date.now().toString(36) + Math.random().toString(36).slice(2);
    sessionStorage.setItem("{key}", page);
  }}
  localStorage.setItem("viser-user:{key}-{client}", page);
}})();"""
VISIBILITY_JS = """(() => {{
  const key = "viser-user:{key}";
  const put = () => localStorage.setItem(key, document.hidden ? "1" : "0");
  document.addEventListener("visibilitychange", put);
  put();
}})();"""


def run_js(client: viser.ClientHandle, source: str) -> None:
    """Run JavaScript `source` in the client's page (viser's own way, as it loads plotly).

    Parameters
    ----------
    client : viser.ClientHandle
    source : str
        The script.
    """
    client._websock_connection.queue_message(_messages.RunJavascriptMessage(source=source))


@dataclass(frozen=True)
class Resume:
    """What a closed tab leaves to the next tab of its page (a reload).

    Attributes
    ----------
    state : TabState
        As the technician left it: the click mode, the selected mirror, the boundaries and region
        being drawn, the view; not a pick, nor a proposal, which were that tab's.
    heat : bool
        Whether its heat map was on.
    true_colour : bool
        Whether its cloud was in true colour (else in its sources' colours).
    """

    state: TabState
    heat: bool
    true_colour: bool = True


class TabPresence:
    """The page, visibility and lag of a tab, and the work it takes up from the page's tab before;
    mixed into `mirrorscan.tab.Tab`.

    Uses the tab's `client`, `closed`, `drawn`, `_stale` (send both halves of the cloud next) and
    `_send_screen`; to take up work, its `_lock`, `state`, `heat`, `true_colour`, `header`,
    `_on_session` and `look`.
    """

    client: viser.ClientHandle
    closed: bool
    drawn: Session
    _stale: bool

    def _init_presence(self) -> None:
        """Start as a page not yet identified, in view and keeping up."""
        self.page: str | None = None      # which browser page this is, once identify() asked it
        self.hidden = False
        self.lagging = False              # see MAX_LAG_S
        # time.perf_counter() when it last lagged, once settled (SETTLING_S)
        self.lagged_at = -np.inf
        self._opened = time.perf_counter()
        # the session the page is known to have been sent (its `drawn` before a question it
        # answered), and whether it was sent a newer one since
        self.seen = self.drawn
        self._unseen = threading.Event()

    def identify(self, timeout: float = 10.0) -> str | None:
        """Ask the page which it is (PAGE_JS: the same through its reloads, its own among tabs).

        Parameters
        ----------
        timeout : float, optional
            Seconds.

        Returns
        -------
        str or None
            The page's name, also kept in `page`; None when the page does not answer within
            `timeout` seconds or went away.
        """
        key = f"{PAGE_KEY}-{self.client.client_id}"
        run_js(self.client, PAGE_JS.format(key=PAGE_KEY, client=self.client.client_id))
        try:
            answer = self.client.local_storage.get_item(key, timeout=timeout)
        except (TimeoutError, RuntimeError):
            return None
        # a name, not a store: PAGE_JS makes about 20 characters
        self.page = answer[:PAGE_NAME_CHARS] if answer else None
        return self.page

    def _watch_visibility(self) -> None:
        """Ask the browser to note in its localStorage whether this tab is hidden."""
        run_js(self.client, VISIBILITY_JS.format(key=f"{HIDDEN_KEY}-{self.client.client_id}"))

    def _watch_acknowledgements(self) -> None:
        """Ask the page, after each session drawn (`_unseen` set), whether it is there: then it has
        what it was sent before, and `seen` moves on to it."""
        def loop() -> None:
            while not self.closed:
                if not self._unseen.wait(1.0) or self.closed:
                    continue
                self._unseen.clear()
                drawn = self.drawn
                try:
                    self.client.local_storage.get_item(
                        f"{HIDDEN_KEY}-{self.client.client_id}", timeout=ACK_TIMEOUT_S)
                except TimeoutError:
                    self._unseen.set()
                    continue
                except RuntimeError:             # the tab is going away
                    return
                self.seen = drawn
        threading.Thread(target=loop, name="mirrorscan-tab-seen", daemon=True).start()

    def poll_visibility(self, timeout: float = 2.0) -> None:
        """Read whether the tab is hidden, and whether it lags.

        It lags when its answer took longer than MAX_LAG_S or did not come within `timeout` seconds.
        A tab that comes back, or catches up, gets the current state.

        Parameters
        ----------
        timeout : float, optional
            Seconds.
        """
        # polled from a list of the tabs taken before it went away
        if self.closed:
            return
        start = time.perf_counter()
        try:
            value = self.client.local_storage.get_item(f"{HIDDEN_KEY}-{self.client.client_id}",
                                                       timeout=timeout)
        except TimeoutError:
            self._keeps_up(False)
            return
        except RuntimeError:             # the tab is going away
            return
        self._keeps_up(time.perf_counter() - start <= MAX_LAG_S)
        hidden = value == "1"
        if hidden != self.hidden:
            self.hidden, self._stale = hidden, True
            if not hidden:
                self._send_screen(force=True)

    def _keeps_up(self, keeps_up: bool) -> None:
        # a lag while the page first builds is not reported
        """Note whether the tab keeps up; one that catches up is sent the depth frame."""
        if not keeps_up and time.perf_counter() - self._opened > SETTLING_S:
            self.lagged_at = time.perf_counter()
        if keeps_up == self.lagging:
            self.lagging, self._stale = not keeps_up, True
            if keeps_up:
                self._send_screen(force=True)

    def take_up(self, resume: Resume) -> None:
        """Go on with the work of the page's tab before (a reload): its state, view and colouring.

        Nothing is taken up when this tab was closed meanwhile.

        Parameters
        ----------
        resume : Resume
        """
        with self._lock:
            # closed meanwhile (reloaded again at once): too late
            if self.closed:
                return
            self.state = resume.state
        # drafts of mirrors gone since are dropped; the panels follow
        self._on_session()
        if resume.state.view == "depth":
            self.look("depth")
        self.header.colours.take_up(resume.heat, resume.true_colour)

    def resume(self) -> Resume:
        """This tab's work, for the next tab to take up (see Resume)."""
        with self._lock:
            state = replace(self.state, drafts=dict(self.state.drafts), picked_corner=None,
                            picked_marker=None, moving_marker=False, flagged_markers=(),
                            proposal_for=())
        return Resume(state, self.heat, self.true_colour)
