"""The report says plainly when the paper's Table 7 cannot show the fall (issue 26, point 4)."""

from __future__ import annotations

from dempath_bringup.report import table7_reading


def paper(before: float, after: float, floor: tuple[float, float],
          floor_after: tuple[float, float]) -> dict[str, object]:
    return {'before': {'mean_nrmse_pct': before}, 'after': {'mean_nrmse_pct': after},
            'floor': {'mean_nrmse_pct': floor[0], 'mean_nrmse_sd_pct': floor[1]},
            'floor_after': {'mean_nrmse_pct': floor_after[0],
                            'mean_nrmse_sd_pct': floor_after[1]}}


def test_a_floor_that_moves_with_the_model_is_said_to_hide_the_fall() -> None:
    """The demo's figures: Table 7 rises while the fitted model's own floor rose more."""
    text = table7_reading(paper(17.14, 19.85, (7.02, 0.34), (19.97, 1.63)))
    assert 'Table 7 cannot show this fall' in text
    assert '7.02 % for the model before, 19.97 +- 1.63 %' in text and 'lies inside' in text


def test_floors_alike_let_table7_be_read() -> None:
    text = table7_reading(paper(30.0, 20.0, (19.0, 1.0), (19.5, 1.0)))
    assert 'cannot show' not in text and 'can be read beside the headline' in text


def test_without_both_floors_nothing_is_claimed() -> None:
    assert table7_reading(None) == ''
    assert table7_reading({'before': {}, 'after': {}, 'floor': None}) == ''
