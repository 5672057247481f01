"""MINRES banded linear solver core (section VI-A of 001): KKT system, storage scheme, golden models, design."""
