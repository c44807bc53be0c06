"""Compilation: the JAX set-up (:mod:`.setup`), the kernel decorator and its persistent store
(:mod:`.kernel`), and the small linear-algebra kernels (:mod:`.linalg`)."""
