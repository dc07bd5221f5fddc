"""Task file of the independent solution (similarity tests)."""
import occgrid


class ogm_continous_S_CSM(occgrid.Base):
    kind = "continuous"
    labelled = True
