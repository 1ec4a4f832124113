"""Reader stub: filled in by the prisma reader work."""


def read(path):
    return None
