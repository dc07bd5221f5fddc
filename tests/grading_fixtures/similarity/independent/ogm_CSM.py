"""Task file of the independent solution (similarity tests)."""
import occgrid


class ogm_CSM(occgrid.Base):
    kind = "discrete"
    labelled = False
