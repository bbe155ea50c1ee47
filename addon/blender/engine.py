"""(placeholder until its owner fills it in)."""


def register():
    pass


def unregister():
    pass
