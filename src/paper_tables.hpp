#pragma once
// The numbers printed in the paper's tables 2-7 (Dolinsky & Celikovsky), for side-by-side
// reports. Where the paper prints only an order of magnitude ("10^-8") the entry is that power
// and `order_only` is set. The rows are theta1..theta7; the columns Raw, Dig. Filt., CSS.

#include <array>

namespace sid::app {

struct PaperEntry {
  double value;
  bool order_only;
};

struct PaperLevel {
  double sigma_q2;
  std::array<std::array<PaperEntry, 3>, 7> mean;      // [parameter][raw, filtered, css]
  std::array<std::array<PaperEntry, 3>, 7> variance;  // [parameter][raw, filtered, css]
};

/// The "true value" column as printed (θ2 and θ5 are rounded wrongly there; see
/// docs/paper-reproduction.md).
inline constexpr std::array<double, 7> kPaperPrintedTrue = {0.0340, 0.0030, 0.0045, 0.1329,
                                                            0.0170, 0.6189, 0.6189};

inline const std::array<PaperLevel, 3>& paper_levels() {
  static const std::array<PaperLevel, 3> levels = {{
      {1e-8,
       {{{{{0.0010, false}, {0.0361, false}, {0.0359, false}}},
         {{{0.0005, false}, {0.0021, false}, {0.0031, false}}},
         {{{-0.0005, false}, {0.0042, false}, {0.0043, false}}},
         {{{0.1282, false}, {0.1331, false}, {0.1331, false}}},
         {{{0.0165, false}, {0.0168, false}, {0.0169, false}}},
         {{{0.6158, false}, {0.6206, false}, {0.6210, false}}},
         {{{0.6200, false}, {0.6190, false}, {0.6191, false}}}}},
       {{{{{0.0447e-8, false}, {0.1894e-6, false}, {0.0182e-5, false}}},
         {{{0.0086e-8, false}, {0.0382e-6, false}, {0.1022e-5, false}}},
         {{{0.0283e-8, false}, {0.0019e-6, false}, {0.0001e-5, false}}},
         {{{0.0008e-8, false}, {0.0015e-6, false}, {0.0001e-5, false}}},
         {{{0.0004e-8, false}, {0.0011e-6, false}, {0.0011e-5, false}}},
         {{{0.3448e-8, false}, {0.0125e-6, false}, {0.0151e-5, false}}},
         {{{0.1180e-8, false}, {0.0004e-6, false}, {0.0003e-5, false}}}}}},
      {1e-6,
       {{{{{0.0007, false}, {0.0330, false}, {0.0366, false}}},
         {{{0.0004, false}, {0.0029, false}, {0.0024, false}}},
         {{{-0.0004, false}, {0.0045, false}, {0.0041, false}}},
         {{{0.1255, false}, {0.1328, false}, {0.1331, false}}},
         {{{0.0183, false}, {0.0169, false}, {0.0168, false}}},
         {{{0.4561, false}, {0.6207, false}, {0.6209, false}}},
         {{{0.5126, false}, {0.6192, false}, {0.6192, false}}}}},
       {{{{{1e-8, true}, {0.1736e-5, false}, {0.3771e-4, false}}},
         {{{1e-8, true}, {0.0026e-5, false}, {0.0036e-4, false}}},
         {{{1e-8, true}, {0.0007e-5, false}, {0.0023e-4, false}}},
         {{{0.0002e-4, false}, {0.0018e-5, false}, {0.0032e-4, false}}},
         {{{0.0001e-4, false}, {0.0001e-5, false}, {0.0003e-4, false}}},
         {{{0.1537e-4, false}, {0.0013e-5, false}, {0.0038e-4, false}}},
         {{{0.0511e-4, false}, {0.0002e-5, false}, {0.0002e-4, false}}}}}},
      {1e-4,
       {{{{{1e-5, true}, {0.0131, false}, {0.0454, false}}},
         {{{1e-5, true}, {0.0051, false}, {-0.0032, false}}},
         {{{1e-5, true}, {0.0054, false}, {0.0030, false}}},
         {{{0.1225, false}, {0.1308, false}, {0.1338, false}}},
         {{{0.0202, false}, {0.0173, false}, {0.0158, false}}},
         {{{0.0179, false}, {0.6211, false}, {0.6209, false}}},
         {{{0.0279, false}, {0.6188, false}, {0.6206, false}}}}},
       {{{{{1e-10, true}, {0.2434e-3, false}, {0.0016, false}}},
         {{{1e-10, true}, {0.0038e-3, false}, {0.0001, false}}},
         {{{1e-10, true}, {0.0017e-3, false}, {1e-4, true}}},
         {{{0.0024e-6, false}, {0.0019e-3, false}, {1e-4, true}}},
         {{{0.0007e-6, false}, {0.0001e-3, false}, {1e-4, true}}},
         {{{0.1526e-6, false}, {0.0023e-3, false}, {1e-4, true}}},
         {{{0.9735e-6, false}, {0.0003e-3, false}, {1e-4, true}}}}}},
  }};
  return levels;
}

/// The paper's level for sigma_q2, or nullptr when the paper has none.
inline const PaperLevel* paper_level(double sigma_q2) {
  for (const auto& level : paper_levels())
    if (sigma_q2 > 0.999 * level.sigma_q2 && sigma_q2 < 1.001 * level.sigma_q2) return &level;
  return nullptr;
}

}  // namespace sid::app
