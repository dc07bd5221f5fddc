"""Task file of the independent solution (similarity tests)."""
import occgrid


class ogm_continuous_CSM(occgrid.Base):
    kind = "continuous"
    labelled = False
