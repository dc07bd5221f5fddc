"""Task file of the template-speed test submission (loops in mapping_core, at template speed)."""
import mapping_core


class ogm_CSM(mapping_core.TemplateMap):
    semantic = False

    def build_ogm(self):
        mapping_core.discrete(self, self.semantic)
        mapping_core.summarise(self, self.semantic)
