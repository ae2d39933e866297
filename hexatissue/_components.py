"""Connected components of an edge list: the one helper behind every grouping of touching things.

(Regions that touch across a torus edge, watershed labels that are copies of
one cell, overlap candidates of the tracker, points within a tolerance,
assignment clusters.)
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def components(n, a, b):
    """Component number of each of ``n`` nodes joined by the undirected edges ``a[k] -- b[k]``.

    Returns
    -------
    ndarray of int32, shape (n,)
        Components are numbered 0, 1, ... in order of their smallest node
        (scipy's convention); a node without an edge is a component of its own.
    """
    a, b = np.asarray(a), np.asarray(b)
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))  # float: repeated edges sum without overflow
    return connected_components(graph, directed=False)[1]
