"""frictionid: identify zone-wise Coulomb friction coefficients from measured displacements and strains."""

__version__ = "0.1.0"
