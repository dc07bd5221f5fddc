"""Single-bug mutants of the exact test submission (``../exact``), written for the grader's tests.

Each mutant is one task file laid over ``exact/``: the exact class with ONE bug a student could
make. ``MUTANTS[name] = (task, file name, source, diagnosis)``: ``diagnosis`` is a phrase the
report must name ("Most likely: ..."), or None where the report states the reason another way
(a shape error). ``SUBMISSIONS`` groups them four at a time (one per task) so that one grading
run covers four bugs. Every mutant must keep at most half of its task's points.
"""

HEAD = '"""Mutant of the grader\'s test submission: {what}."""\nimport numpy as np\n\nimport mapping_core\n\n'
NAMES = {1: "ogm_CSM", 2: "ogm_continuous_CSM", 3: "ogm_S_CSM", 4: "ogm_continous_S_CSM"}
SEM = {1: False, 2: False, 3: True, 4: True}
MODEL = {1: "discrete", 2: "continuous", 3: "discrete", 4: "continuous"}


def _cls(task, what, init="", build=None):
    build = build or (f"        mapping_core.{MODEL[task]}(self, {SEM[task]})\n"
                      f"        mapping_core.summarise(self, {SEM[task]})\n")
    body = f"class {NAMES[task]}(mapping_core.TemplateMap):\n    semantic = {SEM[task]}\n\n"
    if init:
        body += f"    def __init__(self):\n        super().__init__()\n{init}\n"
    body += f"    def build_ogm(self):\n{build}"
    return NAMES[task] + ".py", HEAD.format(what=what) + body


def _free_column_zeroed(task):  # the free-space lines deleted from the loop
    return f"""        data = self.map['occMap'].data
        for i, k, r, phi in mapping_core.visits(self):
            rng, brg, lab = self.polar[k]
            j = np.nanargmin(np.abs(mapping_core.wrapToPI(brg - phi)))
            px, py, h = self.pose['x'][k][0], self.pose['y'][k][0], self.pose['h'][k][0]
            zk, theta = rng[j], brg[j] + h
            d1 = np.hypot(data[i, 0] - (px + zk * np.cos(theta)), data[i, 1] - (py + zk * np.sin(theta)))
            if d1 < self.l:
                self.map['alpha'][i, lab[j] - 1 if {SEM[task]} else 0] += mapping_core.kernel(d1, self.sigma, self.l)
        mapping_core.summarise(self, {SEM[task]})
"""


LABEL_OFF = """        # alpha indexed by the label (1..6), not label - 1
        free = self.map['alpha'].shape[1] - 1
        for i, k, r, phi in mapping_core.visits(self):
            rng, brg, lab = self.polar[k]
            diff = np.abs(mapping_core.wrapToPI(brg - phi))
            j = np.nanargmin(diff)
            zk = rng[j]
            if r > min(self.z_max, zk + self.w_obstacle / 2) or diff[j] > self.w_beam / 2:
                continue
            if zk < self.z_max and abs(r - zk) < self.w_obstacle / 2:
                self.map['alpha'][i, lab[j]] += 1
            elif r < zk and zk < self.z_max:
                self.map['alpha'][i, free] += 1
        mapping_core.summarise(self, True)
"""

SWAP_AB = """        mapping_core.discrete(self, False)
        self.map['alpha'] = self.map['alpha'][:, ::-1].copy()  # occupied counted as free
        mapping_core.summarise(self, False)
"""

FREE_TO_CLASS1 = """        mapping_core.continuous(self, True)
        a = self.map['alpha']
        a[:, [0, 6]] = a[:, [6, 0]]  # free space written to column 0 (class 1) and back
        mapping_core.summarise(self, True)
"""

NO_HITS = """        prior = self.prior_alpha
        mapping_core.continuous(self, False)
        self.map['alpha'][:, 0] = prior  # the end-point update line deleted
        mapping_core.summarise(self, False)
"""

NEVER = """        mapping_core.summarise(self, False)  # the loop never called
"""


def _var_of(task, expr, what):
    return (f"        mapping_core.{MODEL[task]}(self, True)\n"
            "        a = self.map['alpha']\n"
            "        s = a.sum(axis=1, keepdims=True)\n"
            "        self.map['mean'] = a / s\n"
            f"        p = {expr}  # {what}\n"
            "        self.map['variance'] = p * (1 - p) / (s + 1)\n")


EIGHT = """        self.map['alpha'] = np.hstack([self.map['alpha'], np.full((self.map['size'], 1), self.prior_alpha)])
        mapping_core.discrete(self, True)
        mapping_core.summarise(self, True)  # 8 columns: an eighth class
"""

CONTINUOUS_FOR_DISCRETE = """        mapping_core.continuous(self, False)  # the kernel model in the discrete task
        mapping_core.summarise(self, False)
"""

MUTANTS = {
    "alpha/beta swapped": (1, *_cls(1, "alpha and beta swapped", build=SWAP_AB),
                           "alpha and beta are swapped"),
    "free space never updated": (2, *_cls(2, "free space never updated", build=_free_column_zeroed(2)),
                                 "free space is never updated"),
    "labels off by one": (3, *_cls(3, "label k stored as k+1", build=LABEL_OFF),
                          "label k is stored as k+1"),
    "wrong kernel length": (4, *_cls(4, "kernel length 0.4 m", init="        self.l = 0.4\n"),
                            "kernel length is l = 0.4 m"),
    "obstacle one cell thick": (1, *_cls(1, "w_obstacle = grid_size",
                                         build="        self.w_obstacle = self.grid_size\n"
                                               "        mapping_core.discrete(self, False)\n"
                                               "        mapping_core.summarise(self, False)\n"),
                                "one grid size thick"),
    "wrong sigma0": (2, *_cls(2, "sigma0 = 1", init="        self.sigma = 1.0\n"),
                     "sigma0 = 1"),
    "variance of the wrong class": (3, *_cls(3, "variance of free space",
                                             build=_var_of(3, "self.map['mean'][:, 6:7]",
                                                           "free space's, not the most likely")),
                                    "variance is that of free space"),
    "variance from the mean": (4, *_cls(4, "variance from the mean of the classes",
                                        build=_var_of(4, "self.map['mean'].mean(axis=1, keepdims=True)",
                                                      "mean of the classes")),
                               "mean of the class probabilities"),
    "continuous model for the discrete task": (1, *_cls(1, "continuous model in task 1",
                                                        build=CONTINUOUS_FOR_DISCRETE),
                                               "continuous (kernel) model was submitted"),
    "hits never added": (2, *_cls(2, "occupied evidence never added", build=NO_HITS),
                         "occupied (hit) evidence is never added"),
    "an eighth class": (3, *_cls(3, "an eighth class", build=EIGHT), None),
    "free space to class 1": (4, *_cls(4, "free space and class 1 swapped", build=FREE_TO_CLASS1),
                              "free-space evidence goes to class 1"),
    "map never updated": (1, *_cls(1, "map never updated", build=NEVER),
                          "the map is never updated"),
    "wrong sigma0 (task 4)": (4, *_cls(4, "sigma0 = 0.05", init="        self.sigma = 0.05\n"),
                              "sigma0 = 0.05"),
    "variance of class 1": (3, *_cls(3, "variance of class 1",
                                     build=_var_of(3, "self.map['mean'][:, 0:1]", "class 1's")),
                            "variance is that of class 1"),
    "wrong kernel length (task 2)": (2, *_cls(2, "kernel length 0.1 m", init="        self.l = 0.1\n"),
                                     "kernel length is l = 0.1 m"),
}

SUBMISSIONS = {
    "mutants_a": ["alpha/beta swapped", "free space never updated", "labels off by one",
                  "wrong kernel length"],
    "mutants_b": ["obstacle one cell thick", "wrong sigma0", "variance of the wrong class",
                  "variance from the mean"],
    "mutants_c": ["continuous model for the discrete task", "hits never added", "an eighth class",
                  "free space to class 1"],
    "mutants_d": ["map never updated", "wrong kernel length (task 2)", "variance of class 1",
                  "wrong sigma0 (task 4)"],
}


def write(dest, names):
    """Lay the mutants ``names`` over a copy of ``exact/`` already in ``dest``."""
    for n in names:
        _, fname, text, _ = MUTANTS[n]
        (dest / fname).write_text(text)
