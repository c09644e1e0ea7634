"""Assemblies (section 6 where DEM lives): chains and lattices of bodies in contact.

`geometry` (the contact network of a chain or lattice), `linear` (the stiffness matrix of
bonded linear springs and its 2 / omega_max), `search` (the critical-step search on an
assembly, linear and nonlinear: an ensemble whose Delta t_crit is a distribution), `safe`
(Delta t_safe under three conventions). The compiled kernel is
`reference_impl.integrators.assembly_kernel`.
"""

__all__: list[str] = []
