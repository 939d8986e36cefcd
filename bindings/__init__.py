"""stiffkit._core: the thin f2py layer over the Fortran core.

One extension per signature file (``_field``, ``_sparse``, ``_springs``,
``_calib``, ``_tree``, ``_design``; f2py's runtime support compiled once and
linked into each); the modules of the same name without the underscore are
typed wrappers that put arrays into the core's layout and map the integer
``info`` of every routine to an exception (``errors.check``). Nothing else
in stiffkit calls an extension directly.
"""
