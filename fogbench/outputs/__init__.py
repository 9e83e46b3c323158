"""What fogbench writes, and how it never loses a user's files: atomic files, output folders
replaced only when recognised as fogbench's own, and interruptions that leave nothing
half-written."""
