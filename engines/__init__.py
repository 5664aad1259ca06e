"""Floor 2: one adapter per physics engine behind one contract (:mod:`.contract`), found by name in
:mod:`.registry`; the reference solver is just another adapter.

The layout shows the design, its floors lowest first: the contract and what it exchanges
(:mod:`.contract`, :mod:`.motion`, :mod:`.hooks`, :mod:`.support`); the calibration's rules
(:mod:`.calibration`: knobs and their search, the pick, the η reader, the price, the time-step rule,
the held-out block, the cache, the one routine); the contact engines' base (:mod:`.contact`, its loop
:mod:`.loop`); the adapters, one module per engine (:mod:`.adapters`); the registry and the
conformance checker (:mod:`.registry`, :mod:`.checker`). Imports point down only
(tests/test_layers.py).
"""

#: The engine contract this rockbench runs: an adapter declares the one it is written to
#: (``CONTRACT_VERSION`` on its class), and the registry refuses another (docs/engines.md keeps a table
#: of old hook → new hook for every change). Version 1 (before the declaration existed): the
#: skeleton's hooks ``_world``, ``_start``, ``_advance``, ``_angles``, ``_motion`` and per-adapter
#: settings resolution and calibration; version 2: four batch-shaped methods, the shipped contact
#: and the knobs declared.
CONTRACT_VERSION = 2
