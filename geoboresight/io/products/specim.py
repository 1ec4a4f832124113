"""Reader stub: filled in by the specim reader work."""


def read(path):
    return None
