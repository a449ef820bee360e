"""Studies built on the library: the paper reproduction (:mod:`.paper`) and the speed
figures (:mod:`.perf`). Nothing in the library imports them."""
