"""The paper's published numbers, typed in as reference data (never computed here).

Source: H. Zhao, W. Yang, Y. Chen, Z. Wang, B. Liu and L. Qin, "Tactile Recognition of
Both Shapes and Materials with Automatic Feature Optimization-Enabled Meta Learning",
Table I (closed-set accuracy and efficiency) and Section V-C/V-D (generalisation drops,
adaptive D, PVDF/SG shares, t-SNE indicators). Measured on 36 real classes (12 3D-printed
shapes x resin/wood/aluminium) with a 4-channel PVDF + strain-gauge tactile finger.

Accuracies are in percent, as printed; times in the units printed.
"""

from __future__ import annotations

CITATION: str = (
    'H. Zhao, W. Yang, Y. Chen, Z. Wang, B. Liu and L. Qin, "Tactile Recognition of Both '
    'Shapes and Materials with Automatic Feature Optimization-Enabled Meta Learning", '
    "Table I and Section V"
)

#: Table I columns: (k_shot, n_way), in the printed order.
TABLE_ONE_COLUMNS: tuple[tuple[int, int], ...] = (
    (1, 5),
    (1, 10),
    (1, 12),
    (1, 28),
    (1, 36),
    (3, 5),
    (3, 12),
    (3, 36),
    (5, 5),
    (5, 12),
    (5, 36),
)

_ROWS: dict[str, tuple[float, ...]] = {
    "AFOP-ML": (96.08, 94.69, 94.00, 90.32, 88.74, 98.69, 97.23, 93.65, 98.76, 97.63, 94.56),
    "AFO-MLP-ML": (93.47, 90.09, 87.82, 75.79, 69.64, 97.99, 95.56, 85.78, 98.82, 96.25, 86.22),
    "Direct-Prot-ML": (92.05, 88.79, 86.18, 80.92, 78.47, 96.82, 93.56, 87.89, 97.22, 95.20, 89.87),
    "MAML": (93.28, 86.70, 84.38, 73.99, 70.77, 94.88, 88.61, 63.89, 95.37, 89.32, 68.06),
    "CWT-ResNet-ML": (95.67, 92.47, 91.13, 86.18, 84.24, 98.95, 97.59, 93.52, 99.27, 98.55, 96.15),
    "CNN": (70.72, 41.48, 35.57, 14.86, 14.14, 71.78, 45.68, 45.19, 68.16, 60.94, 66.96),
    "BiLSTM": (68.85, 44.02, 39.20, 16.78, 21.71, 73.59, 55.63, 32.85, 70.43, 59.60, 44.26),
}

#: method -> {(k_shot, n_way): accuracy in percent}, Table I.
TABLE_ONE_ACCURACY_PCT: dict[str, dict[tuple[int, int], float]] = {
    method: dict(zip(TABLE_ONE_COLUMNS, row, strict=True)) for method, row in _ROWS.items()
}

#: method -> (pretrain time as printed, adapt ms per 5-way-5-shot episode), Table I.
TABLE_ONE_TIME: dict[str, tuple[str, float]] = {
    "AFOP-ML": ("~2 s", 391.04),
    "AFO-MLP-ML": ("~2 s", 10241.72),
    "Direct-Prot-ML": ("~2 s", 545.65),
    "MAML": ("~20 min", 72.87),
    "CWT-ResNet-ML": ("~8 min", 1428.30),
    "CNN": ("N/A", 1643.25),
    "BiLSTM": ("N/A", 14495.07),
}

#: Section V-C, 1-shot: AFOP-ML's drop below the closed-set curve at 5-way (pp) and the
#: AFOP-ML minus AFO-MLP-ML gap at 12-way (pp), per protocol.
GENERALISATION_DROP_5WAY_PP: dict[str, float] = {
    "cross-shape": 2.4,
    "cross-material": 4.4,
    "perturbation": 7.7,
}
GAP_TO_AFO_MLP_12WAY_PP: dict[str, float] = {
    "cross-shape": 7.2,
    "cross-material": 7.0,
    "perturbation": 10.1,
}

#: Section V-D / Fig. 6: median chosen D per protocol.
MEDIAN_D: dict[str, int] = {
    "cross-shape": 6,
    "closed-set": 8,
    "perturbation": 9,
    "cross-material": 12,
}

#: Section V-D: share of PVDF features among the selected top-D (fraction); the paper
#: states only these two (SG 79.2 % in cross-shape, PVDF 50.2 % in cross-material).
PVDF_SHARE: dict[str, float] = {
    "cross-shape": 0.208,
    "cross-material": 0.502,
}

#: Fig. 7 (t-SNE of the closed-set top-D features, D=8, 5-way-5-shot).
TSNE_INDICATORS: dict[str, float] = {
    "nn1_shape_accuracy": 0.982,
    "mix_sil": 0.840,
    "dgi": 4.769,
}
TSNE_D: int = 8
