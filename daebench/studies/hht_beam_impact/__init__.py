"""The HHT-α paper reproduced (Guo, Zhang, Chen: "Application of HHT-α method to dynamics of
flexible multibody system with contact and constraint", Acta Physica Sinica 66, 164501,
2017): its protocol and Table 1 (:mod:`.table`), the grid of runs and the page
(:mod:`.study`), one computed verdict per claim (:mod:`.claims`) and the figures
(:mod:`.figures`). `daebench paper` runs it.

May import: :mod:`daebench.workflows`, :mod:`daebench.harness` and the layers below.
"""
