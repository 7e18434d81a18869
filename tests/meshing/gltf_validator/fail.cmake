# Run by the glTF validator test when node is missing at configure time: fail loudly, never skip.
message(FATAL_ERROR "${MSG}")
