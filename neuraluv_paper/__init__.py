"""neuraluv_paper: the paper's reproduction harness, a client of the :mod:`neuraluv` library.

Everything here exists to regenerate the paper's tables and figures beside our
numbers; a user who imports :mod:`neuraluv` to unwrap, atlas, check or repair
never needs it. It is installed with the library; its extra dependencies
(dask, plotly, pyvista, mouette) come with ``pip install "neuraluv[paper]"``,
and a runner that misses one says so in one line.

===============  ==================================================================
``bench``        one runner per table (``neuraluv bench NAME``), provenance, the
                 paper's values, findings written as data (``*.findings.json``)
``baselines``    the compared methods behind one signature (libigl, our BFF,
                 external binaries: BFF v1.6, OptCuts, Blender, xatlas)
``ntk``          the NTK–LBO alignment probes (Table 4 of the paper, tab:ntk_compact_controls)
``damage``       generated damage of UV layouts (``neuraluv bench repair``)
``claims``       the claims checklist read from the committed findings
===============  ==================================================================
"""
