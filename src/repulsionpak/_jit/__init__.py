"""numba compilation, caching and warm-up: the bottom layer, importing nothing of the package.

* :mod:`~repulsionpak._jit.kernels`: serial and parallel builds of ``prange`` kernels
  (:func:`~repulsionpak._jit.kernels.parallel_kernel`), the threading layer, the thread
  count, whether numba's disk cache holds a kernel;
* :mod:`~repulsionpak._jit.signatures`: the shipped list of specialisations a packing
  compiles (``warmup_signatures.json``);
* :mod:`~repulsionpak._jit.warmup`: the first run's warm-up process and the claims that
  split the compilation between it and the packing; what it compiles is a
  :class:`~repulsionpak._jit.warmup.Workload` the package gives it
  (:data:`repulsionpak.warmup.WORKLOAD`);
* :mod:`~repulsionpak._jit.prebuilt`: installing the cache entries compiled when the
  package was built (:mod:`repulsionpak.kernel_cache` builds them);
* :mod:`~repulsionpak._jit.loading`: loading cached kernels without numba's compiler
  set-up.
"""
