"""One viewer's link, measured from its acks, and the frame that fits it (issue 34).

The client acknowledges each frame as it arrives, and answers pings with pongs.

The round trip is the least time a ping took. Pings go out as a session starts and every
PING_EVERY_S while no frame is unacknowledged, so the least of them crossed an idle link.
A frame's own ack time cannot give it on a thin link: it holds the frame's transfer (232
ms for a 720p frame at 1 Mbit/s), and with two frames in flight its wait behind the other.

The delivery rate, from the round trip: a frame sent at s whose ack came back at a spent
min(a - s - rtt, a - a_before) on the link (from when the link was free for it, its send or
the frame before it arriving, to its arrival), and its bytes over that time are one sample;
the rate is the median of the last RATE_WINDOW_S's samples (a frame whose ack came back
within the round trip's jitter gives none). This reads the link whether frames queue on it
or it idles between them, which a rate taken over acks only (bytes acked over time) does
not: idling between frames, that reads the stream's own rate, and a budget taken from it
would shrink the frames for ever.

The frame that fits: at most two frames are in flight (session.py MAX_IN_FLIGHT), and
beside them the frames sent in one round trip (pipe_frames: waiting for the acks to come
back held a 720p stream at 5 Mbit/s and 40 ms to 13.6 fps where loopback gave 20.6), so a
frame whose transfer takes no longer than the frame interval keeps the frame rate, and at
most two frames plus one round trip wait. While the link limits the stream (frames spend
over an interval on it: Link.limiting), a frame's byte budget is HEADROOM of what the link
delivers in an interval. FrameFit meets it by lowering the JPEG quality first (down to
MIN_QUALITY), then the size of frames drawn while time runs, by SCALES (changed at most
once every SCALE_HOLD_S: a new size draws the scene pass again), and only then does the
frame rate fall (the window does that by itself). The bytes a quality gives are predicted
from the frames already sent: their bytes per pixel at quality 80, through JPEG_SIZE
(libjpeg-turbo, 4:2:0, measured on fogbank's gallery at 1280x720 and 640x360: the median
size relative to quality 80). A client that answers no pings gets no budget: its frames are
the view's, as before there was one."""

from __future__ import annotations

import collections
import math
import statistics

PING_EVERY_S = 5.0      # a ping at most this often, when no frame is unacknowledged
RATE_WINDOW_S = 2.0     # the delivery rate is the median of this long's samples
MIN_SAMPLES = 3         # ... once there are this many
JITTER_S = 0.002        # a frame back within this of the round trip gives no rate sample
LATE_FRAMES = 3         # frames in a row over an interval on the link: the link limits
CALM_S = 5.0            # ... until none spent over half an interval on it for this long,
IDLE_SHARE = 0.5        # ... or the stream sends under this share of what the link delivers
GROW = 1.05             # after, the budget grows by this a frame
HEADROOM = 0.8          # a frame's budget: this share of what the link delivers in an interval
MIN_QUALITY = 35        # JPEG quality is not lowered below this: below it, size goes first
SCALES = (1.0, 0.75, 0.5, 0.375)   # side of a playing frame, of its view's
SCALE_HOLD_S = 1.0      # the size changes at most this often
MAX_PIPE_FRAMES = 4     # frames a round trip may hold beyond the two in flight (200 ms at 20 fps)
# JPEG bytes at quality q / bytes at quality 80 (the median over the gallery's frames)
JPEG_SIZE = ((10, 0.425), (20, 0.481), (30, 0.528), (40, 0.601), (50, 0.638), (60, 0.711),
             (70, 0.867), (80, 1.0), (85, 1.092), (90, 1.382), (95, 1.98))


def jpeg_size(q: float) -> float:
    """The bytes of a JPEG at quality q relative to quality 80 (linear between JPEG_SIZE)."""
    qs = [a for a, _ in JPEG_SIZE]
    if q <= qs[0]:
        return JPEG_SIZE[0][1]
    for (q0, s0), (q1, s1) in zip(JPEG_SIZE, JPEG_SIZE[1:]):
        if q <= q1:
            return s0 + (s1 - s0) * (q - q0) / (q1 - q0)
    return JPEG_SIZE[-1][1]


def pipe_frames(rtt: float, interval: float) -> int:
    """Frames sent `interval` s apart during a round trip of `rtt` s (inf: not measured,
    0), at most MAX_PIPE_FRAMES."""
    if rtt == math.inf:
        return 0
    return min(MAX_PIPE_FRAMES, int(rtt / interval))


class Link:
    """The round trip, delivery rate and frame budget of one viewer's link."""

    def __init__(self) -> None:
        self.sends: dict[int, tuple[float, int]] = {}        # frame -> (sent at, bytes)
        self.rates: collections.deque = collections.deque()   # (at, bytes a second)
        self.last_ack = -math.inf
        self.rtt = math.inf                # the least ping's round trip, s
        self.pings: dict[int, float] = {}  # ping id -> sent at
        self.next_ping = 0
        self.last_ping = -math.inf
        self.interval = 1.0 / 30.0         # s between frames (the stream sets it as it sends)
        self.late = 0                      # frames in a row over an interval on the link
        self.limited_at: float | None = None   # when the link last showed that it limits
        self.cap: float | None = None      # a frame's bytes (budget)
        self.sent_bytes: collections.deque = collections.deque()   # (sent at, bytes), 2 s

    def ping(self, now: float) -> int:
        """A ping goes out now; returns its id (the last 8 are awaited: a client that
        answers none keeps no more)."""
        self.pings[self.next_ping] = now
        while len(self.pings) > 8:
            self.pings.pop(next(iter(self.pings)))
        self.next_ping += 1
        self.last_ping = now
        return self.next_ping - 1

    def pong(self, ping: int, now: float) -> None:
        t = self.pings.pop(ping, None)
        if t is not None:
            self.rtt = min(self.rtt, now - t)

    def sent(self, frame: int, nbytes: int, now: float, interval: float) -> None:
        self.sends[frame] = (now, nbytes)
        self.interval = interval
        self.sent_bytes.append((now, nbytes))
        while self.sent_bytes and now - self.sent_bytes[0][0] > 2.0:
            self.sent_bytes.popleft()

    def acked(self, frame: int, now: float) -> None:
        """Frames up to `frame` arrived (an ack covers the frames before it too)."""
        for f in sorted(k for k in self.sends if k <= frame):
            t, n = self.sends.pop(f)
            if self.rtt < math.inf:
                busy = min(now - t - self.rtt, now - self.last_ack)
                if busy > JITTER_S:
                    self.rates.append((now, n / busy))
                on_link = now - t - self.rtt
                self.late = self.late + 1 if on_link > self.interval else 0
                if self.late >= LATE_FRAMES or (self.limited_at is not None and on_link > 0.5 * self.interval):
                    self.limited_at = now
                if self.limited_at is not None and (now - self.limited_at > CALM_S or self._idle(now)):
                    self.limited_at = None
            self._budget(n)
            self.last_ack = now
        while self.rates and now - self.rates[0][0] > RATE_WINDOW_S:
            self.rates.popleft()

    def rtt_s(self) -> float | None:
        return self.rtt if self.rtt < math.inf else None

    def pipe_frames(self) -> int:
        """Frames the stream sends during one round trip (pipe_frames below): the window
        holds them beside its two (session.py Session.window), so that waiting for acks to
        come back does not cap the frame rate, and at most two frames plus one round trip
        wait. 0 until a ping has measured the round trip."""
        return pipe_frames(self.rtt, self.interval)

    def rate_bps(self) -> float | None:
        """Bits a second the link delivers (None without a round trip or samples)."""
        if len(self.rates) < MIN_SAMPLES:
            return None
        return 8.0 * statistics.median(r for _, r in self.rates)

    def _idle(self, now: float) -> bool:
        """Whether the stream sends under IDLE_SHARE of what the link delivers: a link
        that limits is busy with it. Acks late by the server's or the client's own delays
        (a busy page, a stalled event loop) read as time on the link, but not as a link
        kept busy: 4 KB frames 20 ms late read 1.6 Mbit/s of which the stream sends 0.6."""
        rate = self.rate_bps()
        return rate is not None and len(self.sent_bytes) >= 4 and self.stream_bps(now) < IDLE_SHARE * rate

    @property
    def limiting(self) -> bool:
        """Whether the link limits the stream: LATE_FRAMES frames in a row spent over an
        interval on it (their ack time less the round trip), and since then, within
        CALM_S, one spent over half an interval, the stream keeping the link busy (_idle).
        Only then does the rate read the link: a stream of small frames that the link
        carries at once measures the server's and the client's own delays (on loopback,
        4 KB frames read 0.7 Mbit/s)."""
        return self.limited_at is not None

    @property
    def budget(self) -> float | None:
        """A frame's bytes: while the link limits the stream, what it carries in a frame
        interval, with HEADROOM; after, that budget growing by GROW a frame until it is
        twice the frames' (None: no limit). A link that limits again stops the growth, so
        the frames climb back, not jump back, to the size that filled it."""
        return self.cap

    def _budget(self, n: int) -> None:
        rate = self.rate_bps()
        if self.limiting and rate is not None:
            self.cap = HEADROOM * rate / 8.0 * self.interval
        elif self.cap is not None:
            self.cap *= GROW
            if self.cap > 2 * max((b for _, b in self.sent_bytes), default=n):
                self.cap = None

    def stream_bps(self, now: float) -> float:
        """Bits a second sent over the last 2 s."""
        return 8.0 * sum(n for t, n in self.sent_bytes if now - t <= 2.0) / 2.0


class FrameFit:
    """The JPEG quality and the size of a frame that the link carries at the frame rate."""

    def __init__(self) -> None:
        self.bpp80: float | None = None   # bytes per pixel at quality 80 (the frames' running mean)
        self.scale_i = 0
        self.scale_at = -math.inf

    def encoded(self, nbytes: int, pixels: int, quality: int) -> None:
        """A frame went out: `nbytes` at `pixels` and `quality`."""
        bpp = nbytes / max(1, pixels) / jpeg_size(quality)
        self.bpp80 = bpp if self.bpp80 is None else 0.7 * self.bpp80 + 0.3 * bpp

    def quality(self, link: Link, want: int, pixels: int) -> int:
        """The highest quality up to `want` whose frame of `pixels` fits the link's budget
        (MIN_QUALITY, or `want` if lower, when none does)."""
        budget = link.budget
        if budget is None or self.bpp80 is None:
            return want
        floor = min(want, MIN_QUALITY)
        for q in range(want, floor - 1, -5 if want - floor >= 5 else -1):
            if self.bpp80 * pixels * jpeg_size(q) <= budget:
                return q
        return floor

    def scale(self, link: Link, want: int, pixels: int, now: float) -> float:
        """The side, of its view's, of a frame drawn while time runs: the largest of
        SCALES whose frame fits at MIN_QUALITY, changed at most once every SCALE_HOLD_S,
        and up only where the larger one would fit with a quarter to spare; with no
        budget (the link no longer limits), a step up every SCALE_HOLD_S."""
        budget = link.budget
        if now - self.scale_at < SCALE_HOLD_S:
            return SCALES[self.scale_i]
        if budget is None or self.bpp80 is None:
            if self.scale_i > 0:   # the link no longer limits: a step back up a hold
                self.scale_i, self.scale_at = self.scale_i - 1, now
            return SCALES[self.scale_i]
        q = min(want, MIN_QUALITY)
        fits = [self.bpp80 * pixels * s * s * jpeg_size(q) <= budget for s in SCALES]
        best = next((i for i, ok in enumerate(fits) if ok), len(SCALES) - 1)
        if best > self.scale_i or (best < self.scale_i and
                                   self.bpp80 * pixels * SCALES[best] ** 2 * jpeg_size(q) <= 0.75 * budget):
            self.scale_i, self.scale_at = best, now
        return SCALES[self.scale_i]
