"""MINRES banded linear solver of the interior-point method (001): KKT layout, design, golden models, report."""
