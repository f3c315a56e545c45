"""The coherent baselines RPM is measured against: delay-and-sum
back-projection (:mod:`.das`) and range migration (:mod:`.rma`)."""
