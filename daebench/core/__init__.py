"""The bottom layer: data and physics interfaces every other layer builds on. Settings
and their validation (:mod:`.params`), the scene value (:mod:`.scene`; files it is given are
read by :mod:`.bounded_file`'s one rule), the kernel
interface and its numba dispatch (:mod:`.kernels`, :mod:`.dispatch`), a smooth phase's
data and solves (:mod:`.phase`, :mod:`.problem`), mechanical systems (:mod:`.system`),
contact laws and impact records (:mod:`.contact`), what a model's observables mean to
the scorer (:mod:`.observables`), dense linear algebra and the one LCP solver
(:mod:`.linalg`, :mod:`.lcp`), the numba cache (:mod:`.numba_cache`; :mod:`.code_digest`:
what keys a plugin's compiled code), the frame-stack chunks kept while numba compiles
(:mod:`.stack_chunks`) and the environment's on/off switches (:mod:`.switches`).

May import: numpy, scipy, numba and the standard library; nothing else of daebench.
"""
