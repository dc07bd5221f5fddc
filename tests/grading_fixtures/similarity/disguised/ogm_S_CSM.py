import maplib


class ogm_S_CSM(maplib.Params):
    labelled = True

    def build_ogm(self):
        maplib.counting(self, self.labelled)
        maplib.finish(self, self.labelled)
