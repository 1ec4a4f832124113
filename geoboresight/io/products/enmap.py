"""Reader stub: filled in by the enmap reader work."""


def read(path):
    return None
