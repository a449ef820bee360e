"""The interactive-mode paper reproduced (Wang, Liu, Hong: "Dynamic modeling method of
flexible bodies with contact/impact based on interactive mode", Acta Physica Sinica
66(15), 154501, 2017): the three contact treatments (ACM, PFM, IMM) scored from ordinary
run records (:mod:`.measures`) and the runs behind its tables (:mod:`.runs`;
`daebench interactive-mode PART`).

May import: :mod:`daebench.workflows`, :mod:`daebench.harness` and the layers below.
"""
