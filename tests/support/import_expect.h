// Import expectations shared by the importer tests.
#pragma once

#include <vox/base/error.h>
#include <vox/import.h>

#include <gtest/gtest.h>

#include <string>

namespace vox::test {

/// Imports @p file, failing the test (and returning an empty scene) if it throws.
inline vox::Scene importOk(const std::filesystem::path& file,
                           const vox::ImportOptions& options = {}) {
    try {
        return vox::importScene(file, options);
    } catch (const std::exception& e) {
        ADD_FAILURE() << "import failed: " << e.what();
        return {};
    }
}

/// Imports @p file expecting error type E whose message is one line starting with the file;
/// returns the message.
template <typename E>
std::string importError(const std::filesystem::path& file, const vox::ImportOptions& options = {}) {
    try {
        (void)vox::importScene(file, options);
    } catch (const E& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.rfind(file.string(), 0), 0u)
            << "message should start with the file: " << message;
        EXPECT_EQ(message.find('\n'), std::string::npos)
            << "message should be one line: " << message;
        return message;
    } catch (const std::exception& e) {
        ADD_FAILURE() << "wrong exception type: " << e.what();
        return {};
    }
    ADD_FAILURE() << "import succeeded but should have failed";
    return {};
}

}  // namespace vox::test
