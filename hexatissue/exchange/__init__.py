"""Exchange formats: GEFF graphs, Cell Tracking Challenge folders, OME-Zarr label images, AnnData.

- :mod:`~hexatissue.exchange.ctc`: ``write_ctc``, ``check_ctc``, ``read_ctc``
  (masks whose ids are track ids plus ``res_track.txt`` / ``man_track.txt``);
  :func:`hexatissue.open_source` opens such a folder as a tracked movie.
- :mod:`~hexatissue.exchange.geff`: the neighbour graph of every frame and
  the track graph as GEFF stores, and back to networkx and tables.
- :mod:`~hexatissue.exchange.omezarr`: label stacks as an NGFF multiscale image.
- :mod:`~hexatissue.exchange.anndata`: the cells, their features and contact graph for scanpy / squidpy.
- :mod:`~hexatissue.exchange.command`: ``hexatissue export RESULTS --to {geff,ctc,ome-zarr,anndata} OUT``.
"""
