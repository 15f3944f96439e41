"""A thin link on loopback: a TCP relay that delays every byte and paces it through a token
bucket, for measuring the stream as a remote viewer meets it (issue 34). `tc netem` is not
in every kernel (nor in this machine's); this needs none.

Each direction of each connection is a pump: bytes read from one side wait `delay_s` (half
the round trip: both directions together add `rtt_ms`), then leave through the direction's
token bucket at `rate_bps` bits per second in packets of at most MTU bytes, the bucket
holding at most one packet (no burst beyond it). Like a router's queue, each direction
buffers at most `queue_bytes`; past that the relay stops reading, and TCP's own flow control
pushes back on the sender, so a server that writes faster than the link finds its socket
full, as it would on a real thin link. The client -> server direction is delayed but not
paced (a home link's upstream is rarely what limits a viewer's acks)."""

from __future__ import annotations

import asyncio
import collections
import contextlib
import threading
import time

MTU = 1400


class _Pump:
    def __init__(self, reader, writer, delay_s: float, rate_bps: float | None, queue_bytes: int):
        self.reader, self.writer = reader, writer
        self.delay_s, self.queue_bytes = delay_s, queue_bytes
        self.rate = rate_bps / 8.0 if rate_bps else None   # bytes per second
        self.queue: collections.deque[tuple[float, bytes]] = collections.deque()
        self.queued = 0
        self.changed = asyncio.Event()
        self.eof = False

    async def read(self) -> None:
        try:
            while True:
                while self.queued >= self.queue_bytes:   # the router's queue is full: read nothing
                    self.changed.clear()
                    await self.changed.wait()
                data = await self.reader.read(MTU)
                if not data:
                    break
                self.queue.append((time.monotonic() + self.delay_s, data))
                self.queued += len(data)
                self.changed.set()
        except (ConnectionError, OSError):
            pass
        finally:
            self.eof = True
            self.changed.set()

    async def write(self) -> None:
        free = 0.0   # when the link has sent the last packet (monotonic s)
        try:
            while True:
                if not self.queue:
                    if self.eof:
                        break
                    self.changed.clear()
                    await self.changed.wait()
                    continue
                due, data = self.queue[0]
                now = time.monotonic()
                start = max(due, free)
                if self.rate:   # the packet takes len / rate on the wire; the next waits for it
                    free = start + len(data) / self.rate
                if start > now:
                    await asyncio.sleep(start - now)
                self.queue.popleft()
                self.queued -= len(data)
                self.changed.set()
                self.writer.write(data)
                await self.writer.drain()
        except (ConnectionError, OSError):
            pass
        finally:
            with contextlib.suppress(Exception):
                self.writer.close()


class Relay:
    """`Relay(target_port, rate_bps=5e6, rtt_ms=40).start()` listens on 127.0.0.1:`port`
    (a free one unless given) in a thread of its own and relays each connection to
    127.0.0.1:`target_port`; `stop()` closes it."""

    def __init__(self, target_port: int, rate_bps: float | None = None, rtt_ms: float = 0.0,
                 port: int = 0, queue_bytes: int | None = None):
        self.target_port = target_port
        self.rate_bps, self.rtt_ms = rate_bps, rtt_ms
        # a router's queue of about 100 ms at the link's rate, at least 32 KB
        self.queue_bytes = queue_bytes or max(32 * 1024, int((rate_bps or 8e8) / 8 * 0.1))
        self.port = port
        self._loop: asyncio.AbstractEventLoop | None = None
        self._server = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._writers: set = set()

    async def _handle(self, c_reader, c_writer) -> None:
        try:
            s_reader, s_writer = await asyncio.open_connection("127.0.0.1", self.target_port)
        except OSError:
            c_writer.close()
            return
        self._writers |= {c_writer, s_writer}
        half = self.rtt_ms / 2000.0
        down = _Pump(s_reader, c_writer, half, self.rate_bps, self.queue_bytes)
        up = _Pump(c_reader, s_writer, half, None, self.queue_bytes)
        try:
            await asyncio.gather(down.read(), down.write(), up.read(), up.write())
        except asyncio.CancelledError:
            # stop() cancels the connection: end quietly (asyncio's streams read a cancelled
            # handler's exception in a callback, which prints a traceback)
            pass
        finally:
            self._writers -= {c_writer, s_writer}

    def _run(self) -> None:
        self._loop = asyncio.new_event_loop()

        async def main():
            self._main = asyncio.current_task()
            self._server = await asyncio.start_server(self._handle, "127.0.0.1", self.port)
            self.port = self._server.sockets[0].getsockname()[1]
            self._ready.set()
            async with self._server:
                await self._server.serve_forever()
        with contextlib.suppress(asyncio.CancelledError, RuntimeError):
            self._loop.run_until_complete(main())
        self._loop.close()

    def start(self) -> "Relay":
        self._thread = threading.Thread(target=self._run, daemon=True, name="relay")
        self._thread.start()
        if not self._ready.wait(10):
            raise RuntimeError("the relay did not start")
        return self

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def stop(self) -> None:
        """Close the listener and every connection, and end the relay's thread."""
        async def close():
            for w in list(self._writers):   # each connection's pumps end on the closed sockets
                w.transport.abort()
            tasks = [t for t in asyncio.all_tasks() if t not in (asyncio.current_task(), self._main)]
            for t in tasks:
                t.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            # closing the listener ends serve_forever, and with it the loop: last
            asyncio.get_running_loop().call_soon(self._server.close)
        if self._loop and self._server and self._loop.is_running():
            asyncio.run_coroutine_threadsafe(close(), self._loop).result(10)
        if self._thread:
            self._thread.join(10)

    def __enter__(self) -> "Relay":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
