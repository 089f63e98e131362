"""The embedded finite element solver: assembly, interface discretisation, condensation, contact, sensitivities."""
