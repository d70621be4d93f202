"""`bluetooth` for board programs under the suite: a BLE radio whose central is the test
program. It records the services, advertisements and values the program sets, and delivers
connections and writes to the program's irq handler as the ESP32's stack does.

    radio = bluetooth.radio                      # the BLE() the program made
    radio.central_connect(); radio.central_write(uuid, b"(1500,1500)")
"""

import sim

FLAG_BROADCAST, FLAG_READ, FLAG_WRITE_NO_RESPONSE, FLAG_WRITE, FLAG_NOTIFY = 0x1, 0x2, 0x4, 0x8, 0x10
FLAG_READ_ENCRYPTED, FLAG_WRITE_ENCRYPTED = 0x0200, 0x1000
_IRQ_CENTRAL_CONNECT, _IRQ_CENTRAL_DISCONNECT, _IRQ_GATTS_WRITE = 1, 2, 3
radio = None


class UUID:
    def __init__(self, value):
        self.value = str(value).lower()

    def __eq__(self, other):
        return isinstance(other, UUID) and other.value == self.value

    def __hash__(self):
        return hash(self.value)

    def __repr__(self):
        return "UUID('%s')" % self.value


class BLE:
    def __init__(self):
        global radio
        radio = self
        self._active = False
        self._irq = None
        self.values = {}  # handle -> bytes
        self.handles = {}  # uuid string -> value handle
        self.flags = {}  # handle -> flags
        self.advertising = []  # (t_us, interval_us, adv_data, resp_data)
        self.settings = {}  # what config() set
        self.encrypted = False  # the central's link was paired (LE Secure Connections, if le_secure)
        self.dropped = 0  # writes the stack refused: encryption needed, the link not encrypted
        self._conn = 0

    def active(self, on=None):
        if on is None:
            return self._active
        self._active = bool(on)
        return self._active

    def irq(self, handler):
        self._irq = handler

    def config(self, *args, **kwargs):
        self.settings.update(kwargs)  # le_secure, mitm, bond, io: how it pairs
        return None

    def gatts_register_services(self, services):
        if not self._active:
            raise OSError("BLE not active")
        out, handle = [], 1
        for _uuid, characteristics in services:
            handles = []
            handle += 1  # the service declaration
            for uuid, flags in characteristics:
                handle += 2  # declaration and value
                self.handles[uuid.value] = handle
                self.flags[handle] = flags
                self.values[handle] = b""
                handles.append(handle)
            out.append(tuple(handles))
        return tuple(out)

    def gatts_read(self, handle):
        return self.values[handle]

    def gatts_write(self, handle, data, send_update=False):
        self.values[handle] = bytes(data)

    def gatts_set_buffer(self, handle, length, append=False):
        pass

    def gap_advertise(self, interval_us, adv_data=None, resp_data=None, connectable=True):
        self.advertising.append((sim.now_us, interval_us, bytes(adv_data or b""), bytes(resp_data or b"")))

    # --- the central: the test program ---------------------------------------------------------
    def central_connect(self, paired=False):
        """A host connects; paired: it pairs (the link is encrypted) where the program allows it."""
        self._conn += 1
        self.encrypted = bool(paired and self.settings.get("le_secure"))
        self._irq(_IRQ_CENTRAL_CONNECT, (self._conn, 0, b"\x00" * 6))

    def central_disconnect(self):
        self._irq(_IRQ_CENTRAL_DISCONNECT, (self._conn, 0, b"\x00" * 6))

    def central_write(self, uuid, data):
        """A write of data to the characteristic uuid, as a connected host does it."""
        handle = self.handles[uuid.lower()]
        if not self.flags[handle] & (FLAG_WRITE | FLAG_WRITE_NO_RESPONSE):
            raise OSError("characteristic %s is not writable" % uuid)
        if self.flags[handle] & FLAG_WRITE_ENCRYPTED and not self.encrypted:
            self.dropped += 1  # the stack answers "insufficient encryption"; the program never hears
            return
        self.values[handle] = bytes(data)
        self._irq(_IRQ_GATTS_WRITE, (self._conn, handle))

    def central_read(self, uuid):
        handle = self.handles[uuid.lower()]
        if not self.flags[handle] & FLAG_READ:
            raise OSError("characteristic %s is not readable" % uuid)
        return self.values[handle]
