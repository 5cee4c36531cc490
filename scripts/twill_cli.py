"""What the papers' scripts ask the twill binary itself, so that no script keeps its own list."""
import subprocess


def registered_names(twill: str, category: str) -> list:
    """The registered names of a category (`twill list --names CATEGORY`), in the registry's order."""
    out = subprocess.run([twill, "list", "--names", category], check=True, capture_output=True,
                         text=True).stdout
    return out.split()
