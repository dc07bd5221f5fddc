"""Attack: kill the grader (its parent process, and every process it may signal; the test fills
{KILL_PARENT} with True only when the grader runs as root, where this must fail), then a memory
bomb."""
import os
import signal

import mapping_core

if {KILL_PARENT}:
    try:
        os.kill(os.getppid(), signal.SIGKILL)
        print("KILLED THE PARENT")
    except OSError as e:
        print("kill blocked:", e)
    try:  # every process this user may signal (none of the grader's)
        os.kill(-1, signal.SIGKILL)
    except OSError:
        pass


class ogm_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        hog = [bytearray(2**30) for _ in range(64)]
        self.map['mean'] = hog
