import maplib


class ogm_continuous_CSM(maplib.Params):
    labelled = False

    def build_ogm(self):
        maplib.kernel_sum(self, self.labelled)
        maplib.finish(self, self.labelled)
