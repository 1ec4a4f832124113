"""Reader stub: filled in by the hyspex reader work."""


def read(path):
    return None
