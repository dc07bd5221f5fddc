"""Attack: reach the network (a server of the test on 127.0.0.1:{PORT}), then map normally."""
import socket

import mapping_core

try:
    socket.create_connection(("127.0.0.1", {PORT}), timeout=3).sendall(b"leak")
    print("NETWORK REACHED")
except OSError as e:
    print("network blocked:", e)


class ogm_continuous_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        mapping_core.continuous(self, False)
        mapping_core.summarise(self, False)
