"""Broken task 2: free space never updated."""
import mapping_core


class ogm_continuous_CSM(mapping_core.TemplateMap):
    def build_ogm(self):
        mapping_core.continuous(self, False)
        self.map['alpha'][:, 1] = self.prior_alpha
        mapping_core.summarise(self, False)
