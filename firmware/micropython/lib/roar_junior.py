"""The ROAR Junior's logic on MicroPython: the twin of the C++ core's HttpRequestReader,
JuniorControl, L298nDriver and JuniorBoard (firmware/core), decision for decision; a
differential test in the suite runs both on the same requests and clock and compares every
response and every pin.

    board = JuniorBoard()
    reader = HttpRequestReader()
    used, state = reader.feed(data)             # bytes from one connection
    reply, keep_open = board.respond(reader, distance_cm, now_ms)
    (left, right) = board.poll(now_ms)          # every loop: ((in1, in2, duty), (in1, in2, duty))
    board.boot(nvm); board.serial_in(data)      # the key: ["SESSION 00000002"], ["KEY 1a2b3c4d", ...]

Times are whole milliseconds from roar_clock.Clock; duties are permille (0..1000).
"""

from roar_clock import DEAD_TIME_MS, JUNIOR_FAILSAFE_MS
from roar_wire import control, junior, signing, spec

FULL = spec.L298N_DUTY_FULL_SCALE  # [permille]

# HttpRequestReader states, as the C++ HttpRead
INCOMPLETE, COMPLETE, MALFORMED, TOO_LONG = 0, 1, 2, 3
MAX_LINE_BYTES = 256  # [bytes] the request line, without its line end
MAX_REQUEST_BYTES = 2048  # [bytes] request line and headers
HEADER_PREFIX = 32  # [bytes] of each header line looked at
_CR, _LF, _SPACE = 13, 10, 32


class HttpRequestReader:
    """One HTTP/1.x request read byte by byte into fixed buffers: the request line is kept,
    header lines are skipped except "Connection:" and those that declare a body (has_body: the
    body is never read), the request ends at the blank line. Over its
    limits or not "METHOD /target HTTP/1.x", the read ends in TOO_LONG or MALFORMED."""

    def __init__(self):
        self._line = bytearray(MAX_LINE_BYTES)
        self._header = bytearray(HEADER_PREFIX)
        self.reset()

    def reset(self):
        self.state = INCOMPLETE
        self._line_len = self._total = self._header_len = 0
        self._in_request_line = True
        self._at_line_start = False
        self.keep_alive = False
        self.has_body = False  # a body follows the headers (never read: the board refuses it)
        self.method = self.path = self.query = ""

    def feed(self, data):
        """Take bytes until the request is decided: (bytes taken, state)."""
        used = 0
        for byte in data:
            if self.state != INCOMPLETE:
                break
            used += 1
            self._byte(byte)
        return used, self.state

    def _byte(self, byte):
        self._total += 1
        if self._total > MAX_REQUEST_BYTES:
            self.state = TOO_LONG
        elif byte == _CR:
            pass  # line ends are "\r\n" or "\n"
        elif self._in_request_line:
            if byte == _LF:
                if self._parse_line():
                    self._in_request_line = False
                    self._at_line_start = True
                else:
                    self.state = MALFORMED
            elif self._line_len == MAX_LINE_BYTES:
                self.state = TOO_LONG
            else:
                self._line[self._line_len] = byte
                self._line_len += 1
        elif byte == _LF:
            if self._at_line_start:
                self.state = COMPLETE  # the blank line ends the headers
            else:
                self._header_line_end()
                self._at_line_start = True
        else:
            self._at_line_start = False
            if self._header_len < HEADER_PREFIX:
                self._header[self._header_len] = byte + 32 if 65 <= byte <= 90 else byte
                self._header_len += 1

    def _header_line_end(self):
        header = bytes(self._header[:self._header_len])
        if header.startswith(b"connection:"):
            value = header[11:]
            if b"close" in value:
                self.keep_alive = False
            if b"keep-alive" in value:
                self.keep_alive = True
        elif header.startswith(b"content-length:"):  # a body unless all zeros; cut off counts
            if self._header_len == HEADER_PREFIX or header[15:].strip(b"0 \t"):
                self.has_body = True
        elif header.startswith(b"transfer-encoding:"):
            self.has_body = True
        self._header_len = 0

    def _parse_line(self):
        """ "METHOD SP /target SP HTTP/1.x" """
        line, n = self._line, self._line_len
        i = 0
        while i < n and 65 <= line[i] <= 90:
            i += 1
        if i == 0 or i >= n or line[i] != _SPACE:
            return False
        method_end = i
        i += 1
        target = i
        while i < n and _SPACE < line[i] < 127:
            i += 1
        if i == target or line[target] != 47 or i >= n or line[i] != _SPACE:  # 47: '/'
            return False
        target_end = i
        i += 1
        if n - i != 8 or bytes(line[i:i + 7]) != b"HTTP/1.":
            return False
        self.keep_alive = line[i + 7] != 48  # HTTP/1.1 keeps the connection by default, 1.0 does not
        self.method = bytes(line[:method_end]).decode()
        path, _, query = bytes(line[target:target_end]).decode().partition("?")
        self.path, self.query = path, query
        return True


class JuniorControl:
    """Query strings applied parameter by parameter, in order; a query with any parameter not
    understood is refused whole; no request for the failsafe timeout stops both sides."""

    def __init__(self):
        self.motion = junior.STOP
        self.left = FULL  # [permille] until the host sets a speed
        self.right = FULL
        self._heard = False
        self._last_ms = 0

    def apply_query(self, query, now_ms):
        """None when applied, or the one-line reason it was refused (nothing changed)."""
        actions, reason = junior.parse_query(query)
        if reason is not None:
            return reason
        for kind, value in actions:
            if kind == junior.MOTION:
                if value is not None:
                    self.motion = value
            elif kind == junior.LEFT:
                self.left = value
            else:
                self.right = value
        self._heard = True
        self._last_ms = now_ms
        return None

    def timed_out(self, now_ms):
        return not self._heard or now_ms - self._last_ms > JUNIOR_FAILSAFE_MS

    def duties(self, now_ms):
        """Signed per-side duties [permille] to drive now."""
        if self.timed_out(now_ms):
            return 0, 0
        m, left, right = self.motion, self.left, self.right
        if m == junior.FORWARD:
            return left, right
        if m == junior.BACKWARD:
            return -left, -right
        if m == junior.TURN_LEFT:
            return -left, right
        if m == junior.TURN_RIGHT:
            return left, -right
        return 0, 0


COAST = (False, False, 0)


class L298nSide:
    """Direction pins and duty of one side, with a coast of the dead time on each reversal."""

    def __init__(self):
        self._applied = 0  # direction on the pins: -1, 0 (coast), +1
        self._last = 0  # direction before the current coast
        self._coast_since = 0  # [ms]

    def step(self, duty, now_ms):
        want = 1 if duty > 0 else (-1 if duty < 0 else 0)
        if want == 0 or want == -self._applied:  # stop, or reverse: coast first
            if self._applied:
                self._last = self._applied
                self._applied = 0
                self._coast_since = now_ms
            return COAST
        if not self._applied:
            if self._last == -want and now_ms - self._coast_since < DEAD_TIME_MS:
                return COAST
            self._applied = want
        return (want > 0, want < 0, min(abs(duty), FULL))


class JuniorBoard:
    """The Junior's loop: requests through JuniorControl, duties through the L298N sides. With a
    key (set by a key line on the serial console, kept in the board's nvm: signed control,
    PROTOCOL.md 1.3 and 6) only signed queries drive; the rest are refused 403 with the reason."""

    def __init__(self):
        self.control = JuniorControl()
        self.keys = signing.KeyStore()
        self._key_line = signing.KeyLine()
        self._left = L298nSide()
        self._right = L298nSide()

    @property
    def auth(self):
        return self.keys.auth

    def boot(self, nvm):
        """The key in nvm (signing.FileNvm) with a new session: the lines to print ("SESSION ..."
        with a key)."""
        self.keys.boot(nvm)
        return [signing.session_reply(self.auth)] if self.auth.key else []

    def serial_in(self, data):
        """Bytes from the serial console, which carries key lines only: the lines to answer."""
        lines = []
        for byte in data:
            event = self._key_line.feed(byte)
            if event != signing.KEY_NOT_MINE and event != signing.KEY_TAKEN:
                lines.extend(self.keys.on_key_line(event, self._key_line.key))
        return lines

    def respond(self, request, distance_cm, now_ms):
        """(the response bytes, keep the connection open) to a decided request."""
        refused = refusal(request)
        if refused:
            return refused, False
        if request.path != spec.JUNIOR_CONTROL_ROUTE:
            return _reply("404 Not Found", "no such route\n", False), False
        verdict, query = self.auth.check_query(request.query)
        if verdict != control.OK:
            body = signing.refusal(verdict, self.auth)
            status = "400 Bad Request" if verdict == control.SYNTAX else "403 Forbidden"
            return _reply(status, body + "\n", False), False
        refused = self.control.apply_query(query, now_ms)
        if refused is not None:
            return _reply("400 Bad Request", refused + "\n", False), False
        keep = request.keep_alive
        return _reply("200 OK", "%d" % distance_cm, keep), keep

    def poll(self, now_ms):
        """The loop body: the pins to write now, ((in1, in2, duty) left, (...) right)."""
        left, right = self.control.duties(now_ms)
        return self._left.step(left, now_ms), self._right.step(right, now_ms)


def refusal(request):
    """The response with which every port refuses a decided request (malformed, too long, not
    GET, a GET with a body); b"" for a GET its routes answer."""
    if request.state == MALFORMED:
        return _reply("400 Bad Request", "not an HTTP/1.x request\n", False)
    if request.state == TOO_LONG:
        return _reply("400 Bad Request", "request too long\n", False)
    if request.method != "GET":
        return _reply("405 Method Not Allowed", "only GET\n", False)
    if request.has_body:
        return _reply("400 Bad Request", "a GET takes no body\n", False)
    return b""


def _reply(status, body, keep_open):
    return ("HTTP/1.1 %s\r\nContent-Type: text/plain\r\nContent-Length: %d\r\nConnection: %s\r\n\r\n%s"
            % (status, len(body), "keep-alive" if keep_open else "close", body)).encode()
