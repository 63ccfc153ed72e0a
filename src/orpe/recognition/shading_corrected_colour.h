// Colour agreement with the shading regressed out. Under a distant light a surface's grey level is
// its albedo times a function of its normal -- Lambert: ambient + diffuse max(0, n . l), linear in
// the normal wherever the light reaches it. A flat-painted object of a printed model's shape then
// shows a grey gradient that follows its normals (across a cylinder, from face to face of a box),
// and some turn of the print can correlate with that gradient by chance: the plain NCC of the
// recogniser's colour test (the best over the pose and its confusable turns) measured 0.11 and 0.28
// for two flat-painted distractors of synthetic seed 4 (docs/RESULTS.md, session 10). Regressing a
// constant and the three components of the sample normal (camera frame) out of both grey signals
// before correlating leaves a flat-painted surface with noise only, while a print keeps what its
// layout does not share with the normals.
#pragma once

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/pose/colour_score.h"

namespace orpe {

/// The weighted NCC between the model's grey levels and the image's over the samples
/// colour_agreement uses (visible_colour_samples, params.depth_tolerance_m, no mask), after a
/// weighted least-squares fit of a + b . n (n: the sample normal in the camera frame) is subtracted
/// from each signal. Not valid (no evidence) with fewer than params.min_pixels samples, or when
/// either residual is flat (variance under 1e-6: a model whose grey levels the normals explain,
/// an image without texture on the object).
/// `model_contrast` (optional): the weighted standard deviation of the model's residual grey levels
/// (0-1), the print's contrast besides its shading (0 when there are too few samples).
ColourAgreement shading_corrected_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                            const ColorImage& image, const DepthImage& depth,
                                            const PinholeIntrinsics& K,
                                            const ColourScoreParams& params,
                                            double* model_contrast = nullptr);

}  // namespace orpe
