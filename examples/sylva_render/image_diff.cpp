// sylva-image-diff A B [MAX_ABS]: compares two images of the same size channel by channel (read
// through OpenImageIO as float: EXR as stored, PNG as 0..1). Prints the largest absolute
// difference, the pixels equal in every channel, and the PSNR over all channels (peak 1;
// "inf" for identical images). Exit status 0 when the largest difference is <= MAX_ABS
// (default 0: bit for bit), 1 when larger, 2 on bad input. Used by the sylva-render tests
// (particle_order_check.cmake) to compare host and Vulkan images within a stated tolerance.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

namespace {

struct Image {
    int width = 0, height = 0, channels = 0;
    std::vector<float> px;
};

bool read_image(const std::string& path, Image& img) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        std::fprintf(stderr, "sylva-image-diff: cannot read %s\n", path.c_str());
        return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    img.width = spec.width;
    img.height = spec.height;
    img.channels = spec.nchannels;
    img.px.resize(static_cast<std::size_t>(img.width) * img.height * img.channels);
    bool ok = in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::FLOAT, img.px.data());
    in->close();
    if (!ok) std::fprintf(stderr, "sylva-image-diff: cannot decode %s\n", path.c_str());
    return ok;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3 || argc > 4) {
        std::fprintf(stderr, "usage: sylva-image-diff A B [MAX_ABS]\n");
        return 2;
    }
    double tolerance = argc == 4 ? std::strtod(argv[3], nullptr) : 0.0;
    Image a, b;
    if (!read_image(argv[1], a) || !read_image(argv[2], b)) return 2;
    if (a.width != b.width || a.height != b.height || a.channels != b.channels) {
        std::fprintf(stderr, "sylva-image-diff: %dx%dx%d and %dx%dx%d differ in size\n", a.width, a.height, a.channels,
                     b.width, b.height, b.channels);
        return 2;
    }
    double max_abs = 0.0, sum_sq = 0.0;
    std::size_t equal_pixels = 0, pixels = static_cast<std::size_t>(a.width) * a.height;
    for (std::size_t p = 0; p < pixels; ++p) {
        bool equal = true;
        for (int c = 0; c < a.channels; ++c) {
            std::size_t i = p * a.channels + c;
            double d = std::fabs(double(a.px[i]) - double(b.px[i]));
            if (!(d == d)) d = std::numeric_limits<double>::infinity();  // NaN on one side only
            equal = equal && a.px[i] == b.px[i];
            max_abs = d > max_abs ? d : max_abs;
            sum_sq += d * d;
        }
        equal_pixels += equal ? 1u : 0u;
    }
    double mse = pixels ? sum_sq / double(pixels * a.channels) : 0.0;
    std::printf("max_abs %.9g equal_pixels %zu of %zu psnr_db ", max_abs, equal_pixels, pixels);
    if (mse == 0.0) std::printf("inf\n");
    else std::printf("%.2f\n", -10.0 * std::log10(mse));
    return max_abs <= tolerance ? 0 : 1;
}
