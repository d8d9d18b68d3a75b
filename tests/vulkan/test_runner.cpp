// The Vulkan compute runner on a real device: lavapipe in CI (SYLVA_VULKAN_DEVICE=cpu).
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <numeric>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/spirv/test_double_words.h"
#include "sylva/spirv/test_split_copy.h"
#include "sylva/spirv/test_triple_words.h"
#include "sylva/vulkan/loop_limit.hpp"
#include "sylva/vulkan/runner.hpp"

namespace {

using sylva::vk::Buffer;
using sylva::vk::Context;
using sylva::vk::Kernel;

/// Sets SYLVA_VULKAN_DEVICE for one scope and restores what was there.
class DeviceRequest {
public:
    explicit DeviceRequest(const char* value) {
        if (const char* old = std::getenv(sylva::vk::device_environment_variable)) saved_ = old;
        ::setenv(sylva::vk::device_environment_variable, value, 1);
    }
    DeviceRequest(const DeviceRequest&) = delete;
    DeviceRequest& operator=(const DeviceRequest&) = delete;
    ~DeviceRequest() {
        if (saved_) {
            ::setenv(sylva::vk::device_environment_variable, saved_->c_str(), 1);
        } else {
            ::unsetenv(sylva::vk::device_environment_variable);
        }
    }

private:
    std::optional<std::string> saved_;
};

/// Lavapipe leaks one-time allocations that only its own globals point to, and the loader unloads
/// it at vkDestroyInstance; LeakSanitizer (SYLVA_SANITIZE=ON) then reports them. One context held
/// for the whole process, never destroyed, keeps the driver loaded and its globals scanned.
void keep_driver_loaded();

}  // namespace

/// Externally visible, so the compiler keeps the pointer that keeps the context reachable.
extern Context* sylva_test_driver_keeper;
Context* sylva_test_driver_keeper = nullptr;

namespace {

void keep_driver_loaded() {
    if (sylva_test_driver_keeper == nullptr) sylva_test_driver_keeper = new Context(Context::create());
}

/// True when the suite runs on a GPU (the tests labelled gpu: SYLVA_VULKAN_DEVICE=gpu).
bool gpu_requested() {
    const char* v = std::getenv(sylva::vk::device_environment_variable);
    return v != nullptr && std::string(v) == "gpu";
}

/// A fresh context on the device under test (lavapipe under the label vulkan, a GPU under gpu),
/// picked through the environment variable.
Context test_context() {
    keep_driver_loaded();
    const DeviceRequest request(gpu_requested() ? "gpu" : "cpu");
    return Context::create();
}

/// 0, 1, 2, ... scrambled so that a misplaced word shows.
std::vector<std::uint32_t> test_words(std::size_t count) {
    std::vector<std::uint32_t> words(count);
    for (std::size_t i = 0; i < count; ++i) words[i] = static_cast<std::uint32_t>(i * 2654435761u + 12345u);
    return words;
}

/// Runs a scale_words.comp kernel over `words` and returns the output.
std::vector<std::uint32_t> run_scale(Context& context, std::span<const std::uint32_t> spirv,
                                     const std::vector<std::uint32_t>& words,
                                     sylva::vk::BufferMemory memory = sylva::vk::BufferMemory::automatic) {
    Kernel kernel(context, spirv, 2, sizeof(std::uint32_t));
    Buffer input(context, words.size() * sizeof(std::uint32_t), memory);
    Buffer output(context, words.size() * sizeof(std::uint32_t), memory);
    input.upload(words);
    const std::array<Buffer*, 2> buffers{&input, &output};
    const auto count = static_cast<std::uint32_t>(words.size());
    const double ms = context.dispatch(kernel, buffers, &count, sizeof count, sylva::vk::groups_for(words.size(), 64));
    CHECK(ms >= 0.0);
    return output.download_words();
}

/// The message of the sylva::Error that `action` throws ("" if it throws none).
template <class Action>
std::string error_message(Action&& action) {
    try {
        action();
    } catch (const sylva::Error& error) {
        return error.what();
    }
    return "";
}

}  // namespace

TEST_CASE("SYLVA_VULKAN_DEVICE=cpu picks lavapipe (=gpu a GPU)", "[vulkan]") {
    Context context = test_context();
    INFO(context.describe());
    CHECK(context.is_cpu() == !gpu_requested());
    CHECK((context.device_type() == VK_PHYSICAL_DEVICE_TYPE_CPU) == !gpu_requested());
    CHECK_FALSE(context.device_name().empty());
    CHECK(context.api_version() >= VK_API_VERSION_1_1);
    CHECK(context.max_storage_buffer_range() >= 65536u);
    CHECK(context.device() != VK_NULL_HANDLE);
    CHECK(context.queue() != VK_NULL_HANDLE);

    Context moved = std::move(context);
    CHECK(moved.is_cpu() == !gpu_requested());
}

TEST_CASE("loops_limited: lavapipe 22 cuts long loops, lavapipe 25 and GPUs do not", "[vulkan]") {
    Context context = test_context();
    const std::uint32_t driver = context.properties().driverVersion;  // Mesa: VK_MAKE_VERSION(major, minor, patch)
    const std::uint32_t major = VK_VERSION_MAJOR(driver);
    INFO(context.describe() << ", driver version " << major << "." << VK_VERSION_MINOR(driver));
    const bool limited = sylva::vk::loops_limited(context);
    if (!context.is_cpu()) CHECK_FALSE(limited);
    if (context.is_cpu() && major == 22) CHECK(limited);   // Debian 12's Mesa 22.3: 65,535 iterations a batch
    if (context.is_cpu() && major >= 25) CHECK_FALSE(limited);  // bookworm-backports' Mesa 25.0
    // Kept with the device: a second call, and a moved context, give the same answer.
    CHECK(sylva::vk::loops_limited(context) == limited);
    Context moved = std::move(context);
    CHECK(moved.shared_device()->loops_limited.load() == (limited ? 1 : 0));
    CHECK(sylva::vk::loops_limited(moved) == limited);
}

TEST_CASE("a device can be requested by index and by part of its name", "[vulkan]") {
    const std::string name = test_context().device_name();
    std::string upper = name.substr(0, std::min<std::size_t>(name.size(), 6));
    std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return char(std::toupper(c)); });
    CHECK(Context::create(upper).device_name() == name);
    CHECK_FALSE(Context::create("0").device_name().empty());
    CHECK_FALSE(Context::create("auto").device_name().empty());
}

TEST_CASE("an unknown SYLVA_VULKAN_DEVICE is an error naming the request", "[vulkan]") {
    keep_driver_loaded();
    const DeviceRequest request("no-such-device");
    const std::string message = error_message([] { (void)Context::create(); });
    INFO(message);
    CHECK(message.find("no-such-device") != std::string::npos);
    CHECK(message.find("SYLVA_VULKAN_DEVICE") != std::string::npos);
    CHECK(error_message([] { (void)Context::create("99"); }).find("'99'") != std::string::npos);
}

TEST_CASE("SYLVA_VULKAN_DEVICE=gpu gives a GPU or an error saying so", "[vulkan]") {
    keep_driver_loaded();
    try {
        const Context context = Context::create("gpu");
        CHECK_FALSE(context.is_cpu());
    } catch (const sylva::Error& error) {
        CHECK(std::string(error.what()).find("'gpu'") != std::string::npos);
    }
}

TEST_CASE("a kernel doubles words, and a define makes it triple them", "[vulkan]") {
    Context context = test_context();
    const std::vector<std::uint32_t> words = test_words(1000);
    const std::vector<std::uint32_t> doubled = run_scale(context, sylva::spirv::test_double_words, words);
    const std::vector<std::uint32_t> tripled = run_scale(context, sylva::spirv::test_triple_words, words);
    REQUIRE(doubled.size() == words.size());
    REQUIRE(tripled.size() == words.size());
    for (std::size_t i = 0; i < words.size(); ++i) {
        INFO("word " << i);
        REQUIRE(doubled[i] == words[i] * 2u);
        REQUIRE(tripled[i] == words[i] * 3u);
    }
}

TEST_CASE("buffers round-trip words and reject transfers out of range", "[vulkan]") {
    Context context = test_context();
    Buffer buffer(context, 16 * sizeof(std::uint32_t));
    // BufferMemory::automatic: staged (device-local) on a discrete GPU, mapped elsewhere.
    CHECK(buffer.host_visible() == (context.device_type() != VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU));
    CHECK(buffer.download_words() == std::vector<std::uint32_t>(16, 0u));
    const std::vector<std::uint32_t> words = test_words(8);
    buffer.upload(words, 4);
    std::vector<std::uint32_t> back(8);
    buffer.download(back, 4);
    CHECK(back == words);
    CHECK_THROWS_AS(buffer.upload(words, 9), sylva::Error);
    CHECK_THROWS_AS(buffer.download(back, 12), sylva::Error);

    Buffer dummy(context, 0);
    CHECK(dummy.size_bytes() == 0);
    CHECK(dummy.bound_bytes() == 4);
    CHECK(dummy.handle() != VK_NULL_HANDLE);
}

TEST_CASE("staged buffers (the discrete-GPU path) round-trip words and feed kernels", "[vulkan]") {
    Context context = test_context();
    Buffer buffer(context, 10 * sizeof(std::uint32_t), sylva::vk::BufferMemory::staged);
    CHECK_FALSE(buffer.host_visible());
    CHECK(buffer.download_words() == std::vector<std::uint32_t>(10, 0u));
    const std::vector<std::uint32_t> words = test_words(6);
    buffer.upload(words, 3);
    std::vector<std::uint32_t> back(6);
    buffer.download(back, 3);
    CHECK(back == words);
    buffer.fill(7u);
    CHECK(buffer.download_words() == std::vector<std::uint32_t>(10, 7u));

    const std::vector<std::uint32_t> many = test_words(777);
    const std::vector<std::uint32_t> doubled =
        run_scale(context, sylva::spirv::test_double_words, many, sylva::vk::BufferMemory::staged);
    REQUIRE(doubled.size() == many.size());
    for (std::size_t i = 0; i < many.size(); ++i) REQUIRE(doubled[i] == many[i] * 2u);
}

TEST_CASE("buffers and kernels keep their device alive after the context is gone", "[vulkan]") {
    std::optional<Context> context = test_context();
    Buffer buffer(*context, 4 * sizeof(std::uint32_t));
    Kernel kernel(*context, sylva::spirv::test_double_words, 2, sizeof(std::uint32_t));
    context.reset();
    const std::vector<std::uint32_t> words{1u, 2u, 3u, 4u};
    buffer.upload(words);
    CHECK(buffer.download_words() == words);
    CHECK(kernel.pipeline() != VK_NULL_HANDLE);
}

TEST_CASE("split words with a forced shift read back identically through a shader", "[vulkan]") {
    Context context = test_context();
    const std::vector<std::uint32_t> words = test_words(3000);
    sylva::vk::SplitWords split = sylva::vk::split_words(context, words, 4, 10);
    REQUIRE(split.shift == 10u);
    REQUIRE(split.parts.size() == 4u);
    CHECK(split.parts[0].size_bytes() == 1024u * 4u);
    CHECK(split.parts[1].size_bytes() == 1024u * 4u);
    CHECK(split.parts[2].size_bytes() == (3000u - 2048u) * 4u);
    CHECK(split.parts[3].size_bytes() == 0u);

    const std::array<std::uint32_t, 1> specialization{split.shift};
    Kernel kernel(context, sylva::spirv::test_split_copy, 5, sizeof(std::uint32_t), specialization);
    Buffer output(context, words.size() * sizeof(std::uint32_t));
    std::vector<Buffer*> buffers = split.bindings();
    buffers.push_back(&output);
    const auto count = static_cast<std::uint32_t>(words.size());
    context.dispatch(kernel, buffers, &count, sizeof count, sylva::vk::groups_for(words.size(), 64));
    CHECK(output.download_words() == words);
}

TEST_CASE("split words choose the largest part that fits one binding", "[vulkan]") {
    Context context = test_context();
    const std::uint32_t shift = sylva::vk::default_split_shift(context);
    CHECK(shift <= sylva::vk::max_split_shift);
    CHECK((std::uint64_t{4} << shift) <= context.max_storage_buffer_range());
    const bool capped = shift == sylva::vk::max_split_shift;
    CHECK((capped || (std::uint64_t{8} << shift) > context.max_storage_buffer_range()));
    const std::vector<std::uint32_t> words = test_words(100);
    const sylva::vk::SplitWords split = sylva::vk::split_words(context, words);
    CHECK(split.shift == shift);
    CHECK(split.parts[0].size_bytes() == 400u);
    CHECK(split.parts[1].size_bytes() == 0u);
}

TEST_CASE("split words reject data that does not fit", "[vulkan]") {
    Context context = test_context();
    const std::vector<std::uint32_t> words = test_words(5000);
    const std::string message = error_message([&] { (void)sylva::vk::split_words(context, words, 4, 10); });
    CHECK(message.find("5000 words do not fit") != std::string::npos);
    CHECK_THROWS_AS(sylva::vk::split_words(context, words, 0, 10), sylva::Error);
    CHECK_THROWS_AS(sylva::vk::split_words(context, words, 4, 31), sylva::Error);
}

TEST_CASE("bad SPIR-V is a sylva::Error, not a crash", "[vulkan]") {
    Context context = test_context();
    const std::span<const std::uint32_t> good(sylva::spirv::test_double_words);
    CHECK(error_message([&] { (void)Kernel(context, {}, 2, 4); }).find("invalid SPIR-V") != std::string::npos);
    const std::vector<std::uint32_t> garbage(64, 0xdeadbeefu);
    CHECK(error_message([&] { (void)Kernel(context, garbage, 2, 4); }).find("magic number 0xdeadbeef") !=
          std::string::npos);
    std::vector<std::uint32_t> corrupt(good.begin(), good.end());
    corrupt[5] = 0xffff0000u | (corrupt[5] & 0xffffu);  // the first instruction claims 65535 words
    CHECK(error_message([&] { (void)Kernel(context, corrupt, 2, 4); }).find("instruction at word 5") !=
          std::string::npos);
    const std::vector<std::uint32_t> truncated(good.begin(), good.begin() + 5);
    CHECK(error_message([&] { (void)Kernel(context, truncated, 2, 4); }).find("no GLCompute entry point") !=
          std::string::npos);
    CHECK(error_message([&] { (void)Kernel(context, good, 1, 4); }).find("binding 1") != std::string::npos);
    CHECK_THROWS_AS(Kernel(context, good, 2, 3), sylva::Error);
}

TEST_CASE("dispatch checks buffers and push constants against the kernel", "[vulkan]") {
    Context context = test_context();
    Kernel kernel(context, sylva::spirv::test_double_words, 2, sizeof(std::uint32_t));
    Buffer a(context, 64);
    Buffer b(context, 64);
    const std::uint32_t count = 16;
    const std::array<Buffer*, 1> one{&a};
    const std::array<Buffer*, 2> two{&a, &b};
    const std::array<Buffer*, 2> with_null{&a, nullptr};
    CHECK(error_message([&] { context.dispatch(kernel, one, &count, 4, 1); }).find("1 buffers given") !=
          std::string::npos);
    CHECK(error_message([&] { context.dispatch(kernel, two, &count, 8, 1); }).find("push constants") !=
          std::string::npos);
    CHECK_THROWS_AS(context.dispatch(kernel, with_null, &count, 4, 1), sylva::Error);
    CHECK_THROWS_AS(context.dispatch(kernel, two, &count, 4, UINT32_MAX), sylva::Error);
    CHECK_NOTHROW(context.dispatch(kernel, two, &count, 4, 1));
}

TEST_CASE("stacks are sized in power-of-two buckets that hold the tree, within the cap", "[vulkan]") {
    // Kernels are specialised for the stack size, so trees of similar depth share one pipeline.
    CHECK(sylva::vk::stack_entries_for(0, 64) == 8u);
    CHECK(sylva::vk::stack_entries_for(8, 64) == 8u);
    CHECK(sylva::vk::stack_entries_for(9, 64) == 16u);
    CHECK(sylva::vk::stack_entries_for(27, 64) == 32u);
    CHECK(sylva::vk::stack_entries_for(33, 64) == 64u);
    CHECK(sylva::vk::stack_entries_for(64, 64) == 64u);
    CHECK(sylva::vk::stack_entries_for(40, 48) == 48u);  // capped, still holding the tree
    CHECK(sylva::vk::stack_entries_for(3, 4) == 4u);
    for (std::uint32_t d = 0; d <= 64; ++d) {
        std::uint32_t e = sylva::vk::stack_entries_for(d, 64);
        CHECK(e >= d);
        CHECK(e <= 64u);
        CHECK(e <= std::max(8u, 2 * d));
    }
}
