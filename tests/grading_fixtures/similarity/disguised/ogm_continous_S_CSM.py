import maplib


class ogm_continous_S_CSM(maplib.Params):
    labelled = True

    def build_ogm(self):
        maplib.kernel_sum(self, self.labelled)
        maplib.finish(self, self.labelled)
