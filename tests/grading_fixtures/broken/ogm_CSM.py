"""Broken task 1: alpha and beta swapped."""
import mapping_core


class ogm_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        mapping_core.discrete(self, False)
        self.map['alpha'] = self.map['alpha'][:, ::-1].copy()
        mapping_core.summarise(self, False)
