"""The neighbour graph and the contact table, against pandas' groupby and hand-made networks."""
import numpy as np
import pandas as pd
import pytest

from hexatissue import contact_table, mesh_from_labels, neighbour_graph
from hexatissue.synthetic import square_labels


@pytest.mark.parametrize("with_frame", [True, False])
def test_contact_table_equals_a_groupby(with_frame):
    rng = np.random.default_rng(0)
    n = 5000
    edges = pd.DataFrame({"frame": rng.integers(0, 7, n), "cell_a": rng.integers(0, 30, n),
                          "cell_b": rng.integers(30, 60, n), "length": rng.random(n)})
    if not with_frame:
        edges = edges.drop(columns="frame")
    keys = (["frame"] if with_frame else []) + ["cell_a", "cell_b"]
    for outside in (False, True):
        kept = edges if outside else edges[edges["cell_a"] != 0]
        ref = kept.groupby(keys, sort=True)["length"].agg(length="sum", n_junctions="size").reset_index()
        pd.testing.assert_frame_equal(contact_table(edges, include_outside=outside), ref, check_exact=False,
                                      rtol=1e-12)


def test_neighbour_graph_of_squares():
    f = mesh_from_labels(square_labels(4, 3, 6))
    g = neighbour_graph(f)
    assert g.number_of_nodes() == 12 and g.number_of_edges() == 17  # 3 x 3 + 4 x 2 shared sides
    assert g.edges[1, 2]["length"] == pytest.approx(6.0)
    assert g.nodes[6]["n_sides"] == 4 and not g.nodes[6]["is_border"]
    assert contact_table(f.edges)["n_junctions"].eq(1).all()
