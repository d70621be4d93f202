"""`network` for board programs under the suite: Wi-Fi that connects at once (or, with
network.fail_connect = True, never), recording what the program asked for."""

STA_IF, AP_IF = 0, 1
AUTH_OPEN, AUTH_WPA_WPA2_PSK = 0, 4
fail_connect = False
interfaces = {}


class WLAN:
    def __init__(self, interface=STA_IF):
        self.interface = interface
        self._active = False
        self.ssid = None
        self.password = None
        self._connected = False
        self.config_args = {}
        interfaces[interface] = self

    def active(self, on=None):
        if on is None:
            return self._active
        self._active = bool(on)

    def connect(self, ssid, password=None):
        self.ssid, self.password = ssid, password
        self._connected = not fail_connect

    def isconnected(self):
        return self._connected

    def config(self, *args, **kwargs):
        self.config_args.update(kwargs)
        if "essid" in kwargs or "ssid" in kwargs:
            self.ssid = kwargs.get("essid", kwargs.get("ssid"))
        if args:
            return self.config_args.get(args[0])

    def ifconfig(self, *args):
        return ("192.168.4.1" if self.interface == AP_IF else "10.0.0.2", "255.255.255.0", "10.0.0.1", "10.0.0.1")

    def status(self, *args):
        return 1010 if self._connected else 1001
