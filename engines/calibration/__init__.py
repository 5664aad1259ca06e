"""The calibration's rules, one module each, the same for every contact engine: the knobs an engine
declares and their search (:mod:`.knobs`, :mod:`.search`), the free-rocking test's η reader
(:mod:`.free_rocking`), the pick (:mod:`.pick`), the price of a row along the base (:mod:`.price`),
the rigid block's answers they are measured against (:mod:`.rigid`), the time-step rule
(:mod:`.step_rule`), the held-out block (:mod:`.held_out`), the cache (:mod:`.cache`) and the one
routine that puts them together (:mod:`.routine`). They run an engine they are given through its
public methods: nothing here imports an adapter."""
