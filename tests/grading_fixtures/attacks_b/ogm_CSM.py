"""Attack: kill the grader (its parent process, and every process it may signal; the test fills
{KILL_PARENT} with True only when the grader runs as root, where this must fail), then a memory
bomb."""
import os
import signal

import mapping_core

if {KILL_PARENT}:
    parent = os.getppid()  # 0 in a PID namespace of its own: the grader is not visible
    try:
        if parent == 0:
            raise ProcessLookupError("the parent is outside this PID namespace")
        os.kill(parent, signal.SIGKILL)
        print("KILLED THE PARENT")
    except OSError as e:
        print("kill blocked:", e)
    for pid in os.listdir("/proc"):  # the grader by its command line
        try:
            if pid.isdigit() and b"pytest" in open(f"/proc/{pid}/cmdline", "rb").read():
                os.kill(int(pid), signal.SIGKILL)
                print("KILLED A GRADER PROCESS")
        except OSError:
            pass
    try:  # every process this user may signal (none of the grader's)
        os.kill(-1, signal.SIGKILL)
    except OSError:
        pass


class ogm_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        hog = [bytearray(2**30) for _ in range(64)]
        self.map['mean'] = hog
