"""Attack: flood stdout (20 MB), then map normally."""
import sys

import mapping_core


class ogm_continous_S_CSM(mapping_core.TemplateMap):
    semantic = True

    def build_ogm(self):
        line = "x" * 1023 + "\n"
        for _ in range(20 * 1024):
            sys.stdout.write(line)
        mapping_core.continuous(self, True)
        mapping_core.summarise(self, True)
