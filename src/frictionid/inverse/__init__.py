"""Identification: parameters, observations, objective, Jacobians, optimisers, uncertainty."""
