"""Attack (or bug): a loop that never ends (a while on a variable it never updates)."""
import mapping_core


class ogm_continous_S_CSM(mapping_core.TemplateMap):
    semantic = True

    def build_ogm(self):
        i = 0
        while i < self.map['size']:
            pass
