"""Attack: a memory bomb."""
import mapping_core


class ogm_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        hog = [bytearray(2**30) for _ in range(64)]
        self.map['mean'] = hog
