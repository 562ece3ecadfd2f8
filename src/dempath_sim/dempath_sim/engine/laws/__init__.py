"""Contact laws, one module each (as LAMMPS / LIGGGHTS pair styles): `hertz_mindlin` (normal and
tangential), `rolling_epsd2` (rolling resistance, type C), `cohesion_sjkr` (SJKR cohesion), and
`dispatch`, which tabulates the pair constants and applies the laws a contact needs.
"""
