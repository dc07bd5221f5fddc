"""Attack: memory spread over forks (each under the per-process limit, 1.5 GB together)."""
import os, time
kids = []
for i in range(6):
    pid = os.fork()
    if pid == 0:
        b = bytearray(250 * 2**20)
        for k in range(0, len(b), 4096): b[k] = 1
        time.sleep(30); os._exit(0)
    kids.append(pid)
time.sleep(30)
