"""Exact sensitivities of equilibria and limit points with respect to design parameters
(implicit differentiation of the KKT system), their finite-difference check, and inverse design."""
