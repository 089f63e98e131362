"""Model builders: the block reference test, the bolt-nut connection, a user's mesh file."""
