"""TEMPORARY naive stand-in (replaced by helper's module on merge)."""
import moocore
import numpy as np


def greedy_least_contributor_removal(f, ref, n_remove):
    idx = np.arange(len(f))
    f = np.asarray(f, float)
    for _ in range(n_remove):
        k = int(np.argmin(moocore.hv_contributions(f, ref=ref)))
        f = np.delete(f, k, axis=0)
        idx = np.delete(idx, k)
    return idx
