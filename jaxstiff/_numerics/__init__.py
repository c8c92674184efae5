"""L0 numerics: pure JAX building blocks that know nothing of robots (small linear algebra, the 3x3
Jacobi eigen-solver, gradient-safe elementwise functions, the fusion boundary, batch-shape checks).
Everything here is shared by at least two higher modules; nothing here imports from jaxstiff."""
