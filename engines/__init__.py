"""Floor 2: one adapter per physics engine behind one contract (:mod:`.base`), found by name in
:mod:`.registry`; the reference solver is just another adapter."""
