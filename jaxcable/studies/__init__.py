"""System-agnostic studies: QMC sampling, batching and device sharding, the resumable sweep runner,
optimisers and the benchmark harness. Nothing here imports a system: systems register their case
functions and design problems by name (:mod:`jaxcable.studies.registry`)."""
