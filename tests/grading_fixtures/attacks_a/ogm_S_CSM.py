"""Attack: write outside the scratch folder and leave a daemon behind, then map normally."""
import os
import sys

import mapping_core

for target in ("/tmp/hw4-attack-{TOKEN}", "/var/tmp/hw4-attack-{TOKEN}",
               "/dev/shm/hw4-attack-{TOKEN}", "{OUTSIDE}/hw4-attack-{TOKEN}",
               "../hw4-attack-{TOKEN}"):
    try:
        with open(target, "w") as f:
            f.write("owned")
        print("WROTE", target)
    except OSError as e:
        print("write blocked:", target, e)

if os.fork() == 0:  # a daemon: new session, second fork, exec a sleeper tagged with the token
    os.setsid()
    if os.fork() == 0:
        os.execv(sys.executable, [sys.executable, "-c", "import time; time.sleep(600)",
                                  "hw4-daemon-{TOKEN}"])
    os._exit(0)


class ogm_S_CSM(mapping_core.TemplateMap):
    semantic = True

    def build_ogm(self):
        mapping_core.discrete(self, True)
        mapping_core.summarise(self, True)
