"""placeholder (being written)"""
def ph_form(description, sym):
    raise NotImplementedError
def ph_functions(prog, sym, form):
    raise NotImplementedError
