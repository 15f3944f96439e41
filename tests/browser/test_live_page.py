"""A live session in the browser (issue 34, static/live.js): "Share live" gives a link;
several pages watch it (one joining late), the presenter hands control to one of them and
takes it back, and a presenter who leaves ends it for everyone, said so."""

from __future__ import annotations

from pathlib import Path

from pages import new_page, wait_frames

SHOTS = Path(__file__).resolve().parents[2] / "out" / "screenshots"
CONFIRMED = "window.fogbank.store.get().confirmed?.query || ''"


def wait_query(page, part: str, timeout=30000):
    page.wait_for_function(f"({CONFIRMED}).includes({part!r})", timeout=timeout)


def test_share_live_watchers_control_a_late_joiner_and_the_end(server, browser):
    presenter = new_page(browser, server.url + "/?time=3")
    wait_frames(presenter, 3)
    presenter.click("#share-live")
    presenter.wait_for_function("window.fogbank.store.get().live?.token")
    link = presenter.evaluate("navigator.clipboard.readText()")
    token = presenter.evaluate("window.fogbank.store.get().live.token")
    assert link == f"{server.url}/?live={token}"
    assert presenter.locator("#share-live").is_hidden()
    viewers = [new_page(browser, link), new_page(browser, link)]
    for v in viewers:
        wait_frames(v, 3)
    presenter.wait_for_function("window.fogbank.store.get().live.viewers === 2")
    assert presenter.locator("#live-summary").inner_text() == "● Live · 2 watching"
    a, b = viewers
    for v in viewers:
        assert "the presenter has control" in v.locator("#watching-text").inner_text()
        assert v.locator("#preset").is_disabled()
        assert v.evaluate("document.getElementById('controls').inert") is True
        assert v.url == link   # a viewer's address stays the live link
    # the presenter's look reaches every viewer
    presenter.select_option("#preset", "forest-shafts")
    wait_query(presenter, "sun.azimuth=45")
    shown = presenter.evaluate(CONFIRMED)
    for v in viewers:
        v.wait_for_function(f"({CONFIRMED}) === {shown!r}")
    # control handed to viewer a: its change reaches the presenter and viewer b
    a_id = a.evaluate("window.fogbank.store.get().live.you")
    presenter.click("#live > summary")
    presenter.click(f"#live-viewers button[data-viewer='{a_id}']")
    a.wait_for_function("document.getElementById('watching-text').textContent.includes('you have control')")
    assert a.locator("#preset").is_enabled()
    presenter.wait_for_function("document.getElementById('preset').disabled")
    assert "another viewer has control" in b.locator("#watching-text").inner_text()
    SHOTS.mkdir(parents=True, exist_ok=True)
    presenter.screenshot(path=str(SHOTS / "live-presenter.png"))
    a.screenshot(path=str(SHOTS / "live-viewer-control.png"))
    a.select_option("#preset", "default")
    a.wait_for_function(f"({CONFIRMED}) !== {shown!r}")
    mine = a.evaluate(CONFIRMED)
    presenter.wait_for_function(f"({CONFIRMED}) === {mine!r}")
    b.wait_for_function(f"({CONFIRMED}) === {mine!r}")
    # a viewer who joins late gets frames and the look as it is now
    late = new_page(browser, link)
    wait_frames(late, 3)
    late.wait_for_function(f"({CONFIRMED}) === {mine!r}")
    presenter.wait_for_function("window.fogbank.store.get().live.viewers === 3")
    b.screenshot(path=str(SHOTS / "live-viewer.png"))
    # the presenter takes control back
    presenter.click("#live-take")
    presenter.wait_for_function("!document.getElementById('preset').disabled")
    a.wait_for_function("document.getElementById('preset').disabled")
    # the presenter leaves: each viewer is told, and offered the look it ended on
    presenter.context.close()
    for v in (a, b, late):
        v.wait_for_function("document.getElementById('watching-text').textContent.includes('has ended')")
        assert "the presenter left" in v.locator("#watching-text").inner_text()
        assert v.locator("#watching-give").inner_text() == "Open this look"
    b.screenshot(path=str(SHOTS / "live-ended.png"))
    for v in (a, b, late):
        assert v.errors == []
        v.context.close()


def blip(page) -> None:
    """The page's socket drops as a network blip does (close 1006 to the page's own handler;
    the server sees the socket end)."""
    page.evaluate("""() => {
        const ws = window.fogbank.stream.ws;
        const onclose = ws.onclose;
        ws.onclose = null;
        ws.close();
        onclose({ code: 1006, reason: "" });
    }""")


def test_a_presenters_blip_resumes_its_live_session_for_its_viewers(server, browser):
    """Issue 34: a presenter's page whose socket drops reconnects with its room and resume
    key and gets its live session back: the same token, its viewer still watching (never
    told it ended), the look it had, and a change made after the blip reaches the viewer.
    Its sockets' rooms: the same before and after (a page sharing nothing takes a fresh
    one: test_page_reconnects_after_the_server_restarts)."""
    from urllib.parse import parse_qs, urlsplit
    rooms = []
    presenter = new_page(browser, server.url + "/?time=3",
                         before=lambda p: p.on("websocket", lambda ws: rooms.append(parse_qs(urlsplit(ws.url).query))))
    wait_frames(presenter, 3)
    presenter.click("#share-live")
    presenter.wait_for_function("window.fogbank.store.get().live?.token")
    token = presenter.evaluate("window.fogbank.store.get().live.token")
    viewer = new_page(browser, f"{server.url}/?live={token}")
    wait_frames(viewer, 3)
    presenter.wait_for_function("window.fogbank.store.get().live.viewers === 1")
    before = presenter.evaluate(CONFIRMED)
    blip(presenter)
    presenter.wait_for_function("window.fogbank.stream.connected && window.fogbank.store.get().live?.token",
                                timeout=20000)
    assert presenter.evaluate("window.fogbank.store.get().live.token") == token
    assert presenter.evaluate("window.fogbank.store.get().live.viewers") == 1
    assert len(rooms) == 2
    assert rooms[1]["room"] == rooms[0]["room"] and "resume" in rooms[1] and "resume" not in rooms[0]
    assert presenter.evaluate(CONFIRMED) == before
    presenter.select_option("#preset", "forest-shafts")
    wait_query(presenter, "sun.azimuth=45")
    viewer.wait_for_function(f"({CONFIRMED}) === {presenter.evaluate(CONFIRMED)!r}")
    assert "has ended" not in viewer.locator("#watching-text").inner_text()
    frames = int(viewer.evaluate("document.getElementById('view').dataset.frames"))
    wait_frames(viewer, frames + 2)
    for p in (presenter, viewer):
        assert p.errors == []
        p.context.close()
