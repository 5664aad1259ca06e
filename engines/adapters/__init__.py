"""One module per engine: each adapter implements the contract (:mod:`rockbench.engines.contract`), a
contact engine the four methods of :class:`~rockbench.engines.contact.ContactEngine`; the registry
names them (:data:`rockbench.engines.registry.BUILTIN`) and imports one only when it is asked for.
Besides the adapters: the row layout PhysX and Genesis share (:mod:`.free_body`), Warp's start for
the engines built on it (:mod:`.warp_start`) and MuJoCo Warp's kernels (:mod:`.mujoco_warp_kernels`)."""
