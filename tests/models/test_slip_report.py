"""The report's models section shows the learning curve when the comparison has one."""

from __future__ import annotations

from odolab.report.models_section import learning_curve_html


def test_learning_curve_table() -> None:
    rows = [
        {"seconds": 10.0, "model": "diff", "endpoint_error": 1.2345, "problem": None},
        {"seconds": 10.0, "model": "icr", "endpoint_error": None, "problem": "x_icr ..."},
        {"seconds": 60.0, "model": "diff", "endpoint_error": 0.4, "problem": None},
        {"seconds": 60.0, "model": "icr", "endpoint_error": 0.3, "problem": None},
    ]
    html = learning_curve_html(rows)
    assert "<th>10 s</th><th>60 s</th>" in html
    assert "<tr><td>diff</td><td>1.234</td><td>0.400</td></tr>" in html
    assert "<tr><td>icr</td><td>not fitted</td><td>0.300</td></tr>" in html
    assert learning_curve_html([]) == ""
