"""Task file of the independent solution (similarity tests)."""
import occgrid


class ogm_S_CSM(occgrid.Base):
    kind = "discrete"
    labelled = True
