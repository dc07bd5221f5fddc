import maplib


class ogm_CSM(maplib.Params):
    labelled = False

    def build_ogm(self):
        maplib.counting(self, self.labelled)
        maplib.finish(self, self.labelled)
