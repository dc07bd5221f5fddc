"""Broken task 4: the grid size is ignored (the map keeps the template's 0.135 m)."""
import mapping_core


class ogm_continous_S_CSM(mapping_core.TemplateMap):
    semantic = True

    def construct_map(self, pose, scan):
        self.grid_size = 0.135
        super().construct_map(pose, scan)

    def build_ogm(self):
        self.map['mean'] = self.map['alpha'] / self.map['alpha'].sum(axis=1, keepdims=True)
        self.map['variance'] = self.map['mean'][:, :1]
