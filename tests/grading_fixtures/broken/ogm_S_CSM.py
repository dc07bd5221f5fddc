"""Broken task 3: label k stored in column k (k+1 in the 1-based class numbers; label 6 in the
free-space column, as `alpha[i, label] += 1` does)."""
import numpy as np

import mapping_core


class ogm_S_CSM(mapping_core.TemplateMap):
    semantic = True

    def build_ogm(self):
        mapping_core.discrete(self, True)
        a = self.map['alpha']
        shifted = np.full_like(a, self.prior_alpha)
        shifted[:, 1:6] = a[:, 0:5]
        shifted[:, 6] = a[:, 6] + a[:, 5] - self.prior_alpha
        self.map['alpha'] = shifted
        mapping_core.summarise(self, True)
