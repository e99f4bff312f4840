from xfemcontact.cli import console

console()
