"""MkDocs hook: the command-line reference page, written from the dresspack parsers at build time."""

MARKER = "<!-- cli-reference -->"


def on_page_markdown(markdown, page, config, files):
    if MARKER not in markdown:
        return markdown
    # imported here, not at load time, so that a site without this page builds without the package's CLI
    from dresspack_gym.cli.reference import cli_reference_markdown

    return markdown.replace(MARKER, cli_reference_markdown())
