"""The tuning report: one self-contained HTML document (optional PDF) built from the user's files.

* :func:`build_report` -- classify the input files (:mod:`~feedtune.report.collect`), build the summary,
  identification, design and time-domain sections from the results stored in the files and the analysis
  functions the CLI uses, and render the HTML (:mod:`~feedtune.report.html`).
* :func:`write_report` -- write the HTML (and the PDF, :mod:`~feedtune.report.pdf`) atomically.
* :func:`write_explore_page` -- the interactive page of a ball-screw gains file on an FRF
  (:mod:`~feedtune.report.explore`, ``feedtune explore``).

See ``docs/report.md``.
"""

from .build import build_report, write_report
from .content import Report
from .explore import explore_data, write_explore_page
from .sections import ReportLimits

__all__ = ["Report", "ReportLimits", "build_report", "explore_data", "write_explore_page", "write_report"]
