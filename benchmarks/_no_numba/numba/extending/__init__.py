"""``numba.extending`` of the stand-in: ``overload`` registers nothing (the Python
function itself runs)."""


def overload(*args, **options):
    """A no-op decorator: interpreted code calls the Python function directly."""
    return lambda impl: impl
