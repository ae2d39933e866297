import numpy as np

from hexatissue._components import components


def test_components_numbered_by_smallest_node():
    # 0-3, 3-5 and 1-4 joined; 2 and 6 alone; edges repeated many times and in both directions
    a = np.r_[np.full(300, 3), 1, 5, 4]
    b = np.r_[np.full(300, 0), 4, 3, 1]
    assert components(7, a, b).tolist() == [0, 1, 2, 0, 1, 0, 3]
    assert components(3, [], []).tolist() == [0, 1, 2]
