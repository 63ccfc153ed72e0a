// Symmetries of an object's appearance (shape and print together), in BOP's sense: a printed box
// whose front differs from its back is not symmetric even though its shape is (issue #15: ADD(-S)
// must then score the rotation, not just the shape). Used by `orpe synth --set
// synth.symmetries=appearance` for the models_info.json it writes.
#pragma once

#include "orpe/synth/objects.h"

namespace orpe::synth {

struct AppearanceSymmetryParams {
  int samples = 3000;            ///< coloured surface samples compared
  double min_correlation = 0.8;  ///< grey-level NCC of p and S(p) (relative to S = identity's)
  int continuous_steps = 12;     ///< a continuous axis is tested at 360 / steps degree turns
};

/// The shape symmetries of `model` (model.symmetries) that also map its colour onto itself: for
/// each transform S, the grey levels of surface samples p and of the sample nearest S(p) must
/// correlate (NCC) at least `min_correlation` times as well as the samples nearest p do with a
/// second, independent sampling (the texture's own resolution). A continuous axis is kept only
/// when every test turn passes. A mesh without texture or vertex colours, or in one flat colour,
/// keeps its shape symmetries. Deterministic.
ObjectSymmetries appearance_symmetries(const ObjectModel& model,
                                       const AppearanceSymmetryParams& params = {});

}  // namespace orpe::synth
