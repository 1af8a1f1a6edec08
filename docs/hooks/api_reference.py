"""MkDocs hook: the package face's API reference, one mkdocstrings block per name in dresspack_gym.PUBLIC."""

MARKER = "<!-- public-api -->"


def public_api_markdown() -> str:
    """One heading-level mkdocstrings block per public name, at the module that defines it."""
    import dresspack_gym

    blocks = []
    for name, module in sorted(dresspack_gym.PUBLIC.items(), key=lambda item: item[0].lower()):
        blocks.append(f"::: dresspack_gym.{module}.{name}\n")
    return "\n".join(blocks)


def on_page_markdown(markdown, page, config, files):
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, public_api_markdown())
