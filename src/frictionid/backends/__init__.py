"""Forward solver backends: each turns zone coefficients into observations (and, if it can, their derivatives)."""
