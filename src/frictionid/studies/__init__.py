"""The shipped studies: the M20 bolt-nut study (bolt) and the block twin experiment (block), shared by the command
line (``frictionid demo``), the examples, the benchmarks and the tests."""
