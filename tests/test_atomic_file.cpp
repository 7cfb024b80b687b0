#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>

#include "test_support.h"

#include <algorithm>
#include <csignal>
#include <sys/wait.h>
#include <unistd.h>

using vox::AtomicFile;
using vox::test::ScratchDir;

TEST(AtomicFile, CommitRenamesIntoPlaceAndLeavesNoTemporary) {
    ScratchDir dir;
    {
        AtomicFile file(dir / "out.bin");
        EXPECT_TRUE(std::filesystem::exists(file.temporaryPath()));
        EXPECT_FALSE(std::filesystem::exists(dir / "out.bin"));
        file.write("hello ");
        file.write("world");
        file.commit();
    }
    EXPECT_EQ(vox::test::readText(dir / "out.bin"), "hello world");
    EXPECT_EQ(dir.files(), std::vector<std::string>{"out.bin"});
}

TEST(AtomicFile, UncommittedFileLeavesThePreviousOutputUntouched) {
    ScratchDir dir;
    vox::test::writeText(dir / "out.bin", "previous");
    {
        AtomicFile file(dir / "out.bin");
        file.write("partial new contents");
    }  // destroyed without commit, as when an exception unwinds
    EXPECT_EQ(vox::test::readText(dir / "out.bin"), "previous");
    EXPECT_EQ(dir.files(), std::vector<std::string>{"out.bin"});
}

TEST(AtomicFile, CommitReplacesAnExistingFile) {
    ScratchDir dir;
    vox::test::writeText(dir / "out.bin", "previous");
    vox::writeFileAtomically(dir / "out.bin", "new");
    EXPECT_EQ(vox::test::readText(dir / "out.bin"), "new");
}

TEST(AtomicFile, WritesLargerThanItsBufferArriveWhole) {
    ScratchDir dir;
    std::string big(300000, '\0');
    for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 7 + i / 256);
    {
        AtomicFile file(dir / "big.bin");
        for (std::size_t at = 0; at < big.size(); at += 1000)
            file.write(big.data() + at, std::min<std::size_t>(1000, big.size() - at));
        file.commit();
    }
    EXPECT_EQ(vox::test::readText(dir / "big.bin"), big);
}

TEST(AtomicFile, MissingDirectoryIsAnIoError) {
    ScratchDir dir;
    try {
        AtomicFile file(dir / "no" / "such" / "dir" / "out.bin");
        FAIL() << "expected IoError";
    } catch (const vox::IoError& e) {
        EXPECT_EQ(e.exitCode(), vox::ExitCode::Io);
        EXPECT_NE(std::string(e.what()).find("out.bin"), std::string::npos) << e.what();
    }
}

TEST(AtomicFile, TemporaryNamesAreRecognisable) {
    ScratchDir dir;
    AtomicFile file(dir / "scene.esvo");
    EXPECT_TRUE(AtomicFile::isTemporaryName(file.temporaryPath().filename().string()))
        << file.temporaryPath();
    EXPECT_FALSE(AtomicFile::isTemporaryName("scene.esvo"));
    EXPECT_FALSE(AtomicFile::isTemporaryName(".tmp-"));
    EXPECT_FALSE(AtomicFile::isTemporaryName("scene.tmp-abcdef"));  // no leading dot
}

namespace {

/// Names in @p dir that have the shape of a temporary.
std::vector<std::string> temporariesIn(const ScratchDir& dir) {
    std::vector<std::string> names;
    for (const std::string& name : dir.files())
        if (AtomicFile::isTemporaryName(name)) names.push_back(name);
    return names;
}

/// Forks a writer of @p target that writes a little and is SIGKILLed before it commits, as a
/// content build's voxelize killed mid-write. Returns the temporary it left.
std::string temporaryOfAKilledWriter(const ScratchDir& dir, const std::filesystem::path& target) {
    const auto before = temporariesIn(dir);
    const pid_t child = ::fork();
    if (child == 0) {
        AtomicFile file(target);
        file.write(std::string(100000, 'k'));
        ::kill(::getpid(), SIGKILL);
        ::_exit(1);
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
    for (const std::string& name : temporariesIn(dir))
        if (std::find(before.begin(), before.end(), name) == before.end()) return name;
    ADD_FAILURE() << "the killed writer left no temporary";
    return {};
}

}  // namespace

TEST(AtomicFile, TheNextWriterOfATargetRemovesTheTemporariesKilledWritersLeft) {
    ScratchDir dir;
    vox::test::writeText(dir / "scene.esvo", "previous");
    const std::string first = temporaryOfAKilledWriter(dir, dir / "scene.esvo");
    ASSERT_FALSE(first.empty());
    EXPECT_EQ(temporariesIn(dir), std::vector<std::string>{first});
    // The second writer removed the first one's before it was killed too.
    const std::string second = temporaryOfAKilledWriter(dir, dir / "scene.esvo");
    ASSERT_FALSE(second.empty());
    EXPECT_EQ(temporariesIn(dir), std::vector<std::string>{second});
    EXPECT_EQ(vox::test::readText(dir / "scene.esvo"), "previous");
    {
        AtomicFile file(dir / "scene.esvo");
        // Only its own temporary is left.
        EXPECT_EQ(temporariesIn(dir),
                  std::vector<std::string>{file.temporaryPath().filename().string()});
        file.write("new");
        file.commit();
    }
    EXPECT_EQ(dir.files(), std::vector<std::string>{"scene.esvo"});
    EXPECT_EQ(vox::test::readText(dir / "scene.esvo"), "new");
}

TEST(AtomicFile, ALiveWritersTemporaryIsNeverRemoved) {
    ScratchDir dir;
    // Another process writing the same target: it holds its temporary until told to finish.
    int ready[2], finish[2];
    ASSERT_EQ(::pipe(ready), 0);
    ASSERT_EQ(::pipe(finish), 0);
    const pid_t child = ::fork();
    if (child == 0) {
        AtomicFile file(dir / "scene.esvo");
        file.write("from the other process");
        char c = 'r';
        if (::write(ready[1], &c, 1) != 1 || ::read(finish[0], &c, 1) != 1) ::_exit(2);
        file.commit();
        ::_exit(0);
    }
    char c = 0;
    ASSERT_EQ(::read(ready[0], &c, 1), 1);
    const auto othersTemporary = temporariesIn(dir);
    ASSERT_EQ(othersTemporary.size(), 1u);
    {
        AtomicFile mine(dir / "scene.esvo");
        AtomicFile alsoMine(dir / "scene.esvo");  // the same process, a second writer: kept too
        EXPECT_EQ(temporariesIn(dir).size(), 3u);
        mine.write("mine");
        mine.commit();
    }
    EXPECT_EQ(vox::test::readText(dir / "scene.esvo"), "mine");
    EXPECT_EQ(temporariesIn(dir), othersTemporary);
    ASSERT_EQ(::write(finish[1], &c, 1), 1);
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    EXPECT_EQ(vox::test::readText(dir / "scene.esvo"), "from the other process");
    EXPECT_EQ(dir.files(), std::vector<std::string>{"scene.esvo"});
    for (int fd : {ready[0], ready[1], finish[0], finish[1]}) ::close(fd);
}

TEST(AtomicFile, CleanUpLeavesOtherTargetsAndOtherNamesAlone) {
    ScratchDir dir;
    const std::string otherTarget = temporaryOfAKilledWriter(dir, dir / "scene.rvol");
    const std::string prefixOfAnother = temporaryOfAKilledWriter(dir, dir / "scene.esvo.bak");
    ASSERT_FALSE(otherTarget.empty());
    ASSERT_FALSE(prefixOfAnother.empty());
    vox::test::writeText(dir / ".scene.esvo.tmp-abc", "not six characters");
    vox::test::writeText(dir / "scene.esvo.tmp-abcdef", "no leading dot");
    std::filesystem::create_directory(dir / ".scene.esvo.tmp-dirdir");
    // Unlocked and shaped like one of scene.esvo's temporaries (an older libvox's, which took no
    // lock): abandoned, so removed.
    vox::test::writeText(dir / ".scene.esvo.tmp-oldver", "abandoned");
    vox::writeFileAtomically(dir / "scene.esvo", "new");
    std::vector<std::string> expected = {".scene.esvo.tmp-abc", ".scene.esvo.tmp-dirdir",
                                         "scene.esvo",          "scene.esvo.tmp-abcdef",
                                         otherTarget,           prefixOfAnother};
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(dir.files(), expected);
}
