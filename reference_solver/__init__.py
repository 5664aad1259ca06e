"""Floor 1: the rocking-block problem and its reference solution.

Block geometry (:mod:`.model`), restitution laws (:mod:`.restitution`), table pulses
(:mod:`.pulses`), energy and the exact post-pulse decision (:mod:`.energy`), the one outcome
classifier (:mod:`.classify`) and the Newmark solver (:mod:`.solver`).
"""
