"""Print the paper's Table 2 beside what impactgen computes: the same as `impactgen paper-table`
(the table is `impactgen.paper.paper_table()`)."""
import sys

from impactgen.cli import main

sys.exit(main(["paper-table", *sys.argv[1:]]))
